// The band coupling of a 3D needle of finite radius (vim/needle/band_coupling.hpp, docs/needle-model.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vim/needle/band_coupling.hpp>
#include <vim/needle/band_load_field.hpp>
#include <vim/needle/tip_bearing.hpp>

namespace vim::needle {

namespace {
// Stations farther from a point than this many times max(R, ℓ) add nothing to its surface-load
// correction that counts: the two loads have the same resultant, so their difference falls as 1/d³.
constexpr double kSurfaceLoadReach = 8.0;
}  // namespace

BandCoupling::BandCoupling(const Geometry& g, const CellLocator<3>& locator,
                           const std::vector<double>& cell_modulus, double poisson_ratio,
                           const std::vector<bool>& blocked, std::vector<fem::Region<3>> held_regions)
    : held_regions_(std::move(held_regions)),
      axis_(g.axis),
      radius_(g.radius),
      poisson_ratio_(poisson_ratio) {
  add_stations(g, locator, cell_modulus, poisson_ratio, blocked);
  if (g.tip_spacing > 0.0) add_tip_rows(g, locator, cell_modulus, poisson_ratio);
  lateral_.assign(stations_.size(), Vec::Zero());
  for (std::size_t v = 0; v < blocked.size(); ++v)
    if (blocked[v]) held_points_.push_back(locator.vertex(static_cast<int>(v)));
}

// Stations of equal length, at most g.spacing, along the path.
void BandCoupling::add_stations(const Geometry& g, const CellLocator<3>& locator,
                                const std::vector<double>& cell_modulus, double poisson_ratio,
                                const std::vector<bool>& blocked) {
  const long n = std::max(1L, static_cast<long>(std::ceil(g.depth / g.spacing - 1e-9)));
  const double length = g.depth / static_cast<double>(n);
  const NeedleBand band = station_band(g.radius, g.coupling_radius, g.element_size, length, g.degree);
  band_ = band;
  coupling_radius_ = band.coupling_radius;
  effective_radius_ = effective_coupling_radius(band);
  std::vector<int> support;
  for (long i = 0; i < n; ++i) {
    const double s = (static_cast<double>(i) + 0.5) * length;
    const Vec centre = g.entry + s * g.axis;
    // The modulus of the cells the band's samples fall in; the station is kept if one of them has a
    // vertex that is not held.
    // Built around the world axis, then brought into the frame (offsets and axes rotate).
    fem::PointConstraint<3> p =
        needle_band_constraint(centre, g.to_world * g.axis, band, Vec::Zero(), 1.0, poisson_ratio);
    p.axes = g.to_world.transpose() * p.axes;
    for (Vec& o : p.offsets) o = g.to_world.transpose() * o;
    double e_sum = 0.0;
    int inside = 0;
    bool free = false;
    for (const Vec& o : p.offsets) {
      const long c = locator.locate(centre + o, &support);
      if (c < 0) continue;
      e_sum += cell_modulus[static_cast<std::size_t>(c)];
      ++inside;
      for (int v : support) free = free || !(static_cast<std::size_t>(v) < blocked.size() && blocked[v]);
    }
    if (inside == 0 || !free) continue;
    // The compliances scale as 1/E: those of E = 1 divided by the band's mean modulus.
    p.compliance /= e_sum / inside;
    stations_.push_back({centre, s, length});
    bands_.push_back(std::move(p));
    moduli_.push_back(e_sum / inside);
  }
}

// Tip rows every g.tip_spacing from the entry: disks of radius R = max(R_band, 2a) (the band's rule from
// the element size, so that the mesh resolves the disk's mean; at least 2a, so that the mesh's part
// C_disk of the punch's compliance is at most half of it), samples spaced ≤ h/2, the modulus the mean
// over the cells the samples fall in. Depth below the free surface: from where the path enters the
// mesh if the entry lies outside it (or on its boundary), else unbounded (embedded).
void BandCoupling::add_tip_rows(const Geometry& g, const CellLocator<3>& locator,
                                const std::vector<double>& cell_modulus, double poisson_ratio) {
  tip_disk_radius_ = needle::tip_disk_radius(coupling_radius_, g.radius);
  const double spacing = tip_sample_spacing(g.element_size, tip_disk_radius_);
  const long n = static_cast<long>(std::floor(g.depth / g.tip_spacing + 1e-9)) + 1;
  const Vec world_axis = g.to_world * g.axis;
  const double surface = free_surface_along(locator, g.entry, g.axis, g.depth);
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * g.tip_spacing;
    const Vec centre = g.entry + t * g.axis;
    fem::PointConstraint<3> p =
        tip_bearing_constraint(centre, world_axis, g.radius, tip_disk_radius_, spacing, 1.0, poisson_ratio,
                               std::max(0.0, t - surface));
    p.axes = g.to_world.transpose() * p.axes;
    for (Vec& o : p.offsets) o = g.to_world.transpose() * o;
    double e_sum = 0.0;
    std::size_t inside = 0;
    for (const Vec& o : p.offsets) {
      const long c = locator.locate(centre + o);
      if (c < 0) continue;
      e_sum += cell_modulus[static_cast<std::size_t>(c)];
      ++inside;
    }
    if (!tip_disk_in_tissue(inside, p.offsets.size())) continue;
    p.compliance /= e_sum / static_cast<double>(inside);
    tips_.push_back({centre, t, 0.0});
    tip_bands_.push_back(std::move(p));
  }
}

// axes = (lateral 1, lateral 2, axis): the loads' lateral offset and the axial value (tip rows: axial).
void BandCoupling::held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                               std::vector<Vec>& held) const {
  held.resize(active.size());
  for (std::size_t i = 0; i < active.size(); ++i) {
    const std::size_t j = active[i];
    if (j >= bands_.size()) {
      held[i] = Vec(0.0, 0.0, axial[j]);
      continue;
    }
    held[i] = Vec(bands_[j].axes.col(0).dot(lateral_[j]), bands_[j].axes.col(1).dot(lateral_[j]), axial[j]);
  }
}

std::vector<double> BandCoupling::axial_forces(const std::vector<std::size_t>& active,
                                               const fem::Solution<3>& solution) const {
  std::vector<double> f(stations_.size() + tips_.size(), 0.0);
  for (std::size_t i = 0; i < active.size() && i < solution.point_force.size(); ++i)
    f[active[i]] = solution.point_force[i].dot(axis_);
  return f;
}

std::vector<BandCoupling::Vec> BandCoupling::displacements(const std::vector<std::size_t>& points,
                                                           const fem::ElasticModel<3>& model) const {
  std::vector<Vec> at;
  for (std::size_t j : points)
    for (const Vec& o : row_template(j).offsets) at.push_back(row_template(j).position + o);
  fem::PointSample info;
  const std::vector<Vec> u = model.sample(at, &info);
  std::vector<Vec> mean(points.size(), Vec::Zero());
  std::size_t q = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    double w = 0.0;
    const fem::PointConstraint<3>& row = row_template(points[i]);
    for (std::size_t k = 0; k < row.offsets.size(); ++k, ++q) {
      if (!info.inside[q]) continue;
      mean[i] += row.weights[k] * u[q];
      w += row.weights[k];
    }
    if (w > 0.0) mean[i] /= w;
  }
  return mean;
}

// As LineCoupling::keep_offsets: the band keeps the lateral mean displacement the loads gave it.
void BandCoupling::keep_offsets(const std::vector<Vec>& u) {
  for (std::size_t j = 0; j < stations_.size() && j < u.size(); ++j)
    lateral_[j] = u[j] - u[j].dot(axis_) * axis_;
}

std::vector<BandCoupling::StationState> BandCoupling::station_states(const std::vector<std::size_t>& active,
                                                                     const std::vector<double>& axial,
                                                                     const fem::Solution<3>& solution) const {
  std::vector<StationState> st;
  for (std::size_t i = 0; i < active.size() && i < solution.point_force.size(); ++i) {
    if (active[i] >= bands_.size()) continue;  // a tip row
    const fem::PointConstraint<3>& b = bands_[active[i]];
    const Vec g_axes(b.axes.col(0).dot(lateral_[active[i]]), b.axes.col(1).dot(lateral_[active[i]]),
                     axial[active[i]]);
    const Vec f_axes = b.axes.transpose() * solution.point_force[i];
    st.push_back({stations_[active[i]].s, b.axes * g_axes, b.axes * b.compliance.cwiseProduct(f_axes)});
  }
  return st;  // in shaft order: the active stations are listed by ascending arc length
}

std::vector<BandCoupling::Vec> BandCoupling::tissue_displacements(const std::vector<Vec>& points,
                                                                  std::vector<Vec> mesh_values,
                                                                  const ShaftState& state,
                                                                  const fem::Solution<3>& solution) const {
  const std::vector<StationState> st = station_states(state.active, state.axial, solution);
  if (st.empty() || effective_radius_ <= radius_) return mesh_values;
  const Vec entry = stations_.front().position - stations_.front().s * axis_;
  // The held tissue ends where the last station's cut part ends (the front).
  double held_end = st.back().s + 0.5 * band_.length;
  if (state.tip < stations_.size() && state.tip < state.carried.size())
    held_end = st.back().s - 0.5 * band_.length + state.carried[state.tip];
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Vec d = points[k] - entry;
    const double t = d.dot(axis_), r = (d - t * axis_).norm();
    const double half = 0.5 * band_.length;
    const bool beside = t >= st.front().s - half && t <= held_end;
    if (beside && r < effective_radius_)
      mesh_values[k] = annulus_value(st, t, r);
    else if (!beside)
      mesh_values[k] += surface_load_correction(points[k], state, solution);
  }
  return mesh_values;
}

// Inside the held prism: ū + φ(r)(g − ū) between the two station centres around arc length t (the
// nearest one beyond the ends), linear in t.
BandCoupling::Vec BandCoupling::annulus_value(const std::vector<StationState>& st, double t, double r) const {
  std::size_t hi = 0;
  while (hi < st.size() && st[hi].s < t) ++hi;
  const std::size_t lo = hi == 0 ? 0 : hi - 1;
  hi = std::min(hi, st.size() - 1);
  const double w = hi == lo ? 0.0 : (t - st[lo].s) / (st[hi].s - st[lo].s);
  const Vec g = (1 - w) * st[lo].g + w * st[hi].g, jump = (1 - w) * st[lo].jump + w * st[hi].jump;
  const double phi =
      std::log(effective_radius_ / std::max(r, radius_)) / std::log(effective_radius_ / radius_);
  return g - (1.0 - phi) * jump;  // ū + φ (g − ū)
}

// Beyond the held shaft's ends: the model carries each station's force f spread over its band (radius
// R, the station's length); the tissue takes it on the needle's surface (radius a) along the shaft the
// station carries — its own length, or up to the tip for the station nearest it — except the station the
// tip pushes, whose load stays at its band. The difference of the two Kelvin fields at x, summed over the
// active stations near x. The unbounded body stands for the tissue between a station and x while the held
// tissue is not much nearer x: none in a held region; with b the distance from x to the nearest held
// vertex, weight 1 for a station within 2b, falling linearly to 0 at 3b.
BandCoupling::Vec BandCoupling::surface_load_correction(const Vec& x, const ShaftState& state,
                                                        const fem::Solution<3>& solution) const {
  for (const auto& region : held_regions_)
    if (region.contains(x)) return Vec::Zero();
  double b = std::numeric_limits<double>::infinity();
  for (const Vec& p : held_points_) b = std::min(b, (p - x).norm());
  Vec du = Vec::Zero();
  for (std::size_t i = 0; i < state.active.size() && i < solution.point_force.size(); ++i) {
    const std::size_t j = state.active[i];
    if (j >= stations_.size()) continue;  // the tip's disk: its load is not corrected
    const ShaftPoint<3>& p = stations_[j];
    const double d = (x - p.position).norm(), w = std::clamp(3.0 - d / b, 0.0, 1.0);
    if (w == 0.0 || d > kSurfaceLoadReach * std::max(coupling_radius_, p.length)) continue;
    NeedleBand surface = band_;
    surface.coupling_radius = radius_;
    surface.inner_fraction = 1.0;
    Vec centre = p.position;
    if (j != state.cutting && j < state.carried.size() && state.carried[j] > 0.0) {
      surface.length = state.carried[j];
      centre += 0.5 * (state.carried[j] - p.length) * axis_;
    }
    const Vec& f = solution.point_force[i];
    du += w * (band_load_displacement(surface, centre, axis_, f, x, moduli_[j], poisson_ratio_) -
               band_load_displacement(band_, p.position, axis_, f, x, moduli_[j], poisson_ratio_));
  }
  return du;
}

}  // namespace vim::needle

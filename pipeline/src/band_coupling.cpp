// The band coupling of a 3D needle of finite radius (needle_coupling.hpp, docs/needle-model.md).
#include <algorithm>
#include <cmath>
#include <vim/fem/needle_band.hpp>
#include <vim/pipeline/needle_coupling.hpp>

namespace vim::pipeline {

BandCoupling::BandCoupling(const Geometry& g, const fem::CellLocator<3>& locator,
                           const std::vector<double>& cell_modulus, double poisson_ratio,
                           const std::vector<bool>& blocked)
    : axis_(g.axis) {
  const long n = std::max(1L, static_cast<long>(std::ceil(g.depth / g.spacing - 1e-9)));
  const double length = g.depth / static_cast<double>(n);
  fem::NeedleBand band;
  if (g.coupling_radius > 0.0) {
    band.radius = g.radius;
    band.coupling_radius = g.coupling_radius;
    band.length = length;
  } else {
    band = fem::default_needle_band(g.radius, g.element_size, length, g.degree);
  }
  coupling_radius_ = band.coupling_radius;
  radius_ = g.radius;
  effective_radius_ = fem::effective_coupling_radius(band);
  std::vector<int> support;
  for (long i = 0; i < n; ++i) {
    const double s = (static_cast<double>(i) + 0.5) * length;
    const Vec centre = g.entry + s * g.axis;
    // The modulus of the cells the band's samples fall in; the station is kept if one of them has a
    // vertex that is not held.
    // Built around the world axis, then brought into the frame (offsets and axes rotate).
    fem::PointConstraint<3> p =
        fem::needle_band_constraint(centre, g.to_world * g.axis, band, Vec::Zero(), 1.0, poisson_ratio);
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
  }
  lateral_.assign(stations_.size(), Vec::Zero());
}

// axes = (lateral 1, lateral 2, axis): the loads' lateral offset and the axial value.
void BandCoupling::held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                               std::vector<Vec>& held) const {
  held.resize(active.size());
  for (std::size_t i = 0; i < active.size(); ++i) {
    const std::size_t j = active[i];
    held[i] = Vec(bands_[j].axes.col(0).dot(lateral_[j]), bands_[j].axes.col(1).dot(lateral_[j]), axial[j]);
  }
}

std::vector<double> BandCoupling::axial_forces(const std::vector<std::size_t>& active,
                                               const fem::Solution<3>& solution) const {
  std::vector<double> f(stations_.size(), 0.0);
  for (std::size_t i = 0; i < active.size() && i < solution.point_force.size(); ++i)
    f[active[i]] = solution.point_force[i].dot(axis_);
  return f;
}

std::vector<BandCoupling::Vec> BandCoupling::displacements(const std::vector<std::size_t>& points,
                                                           const fem::ElasticModel<3>& model) const {
  std::vector<Vec> at;
  for (std::size_t j : points)
    for (const Vec& o : bands_[j].offsets) at.push_back(bands_[j].position + o);
  fem::PointSample info;
  const std::vector<Vec> u = model.sample(at, &info);
  std::vector<Vec> mean(points.size(), Vec::Zero());
  std::size_t q = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    double w = 0.0;
    for (std::size_t k = 0; k < bands_[points[i]].offsets.size(); ++k, ++q) {
      if (!info.inside[q]) continue;
      mean[i] += bands_[points[i]].weights[k] * u[q];
      w += bands_[points[i]].weights[k];
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
    const fem::PointConstraint<3>& b = bands_[active[i]];
    const Vec g_axes(b.axes.col(0).dot(lateral_[active[i]]), b.axes.col(1).dot(lateral_[active[i]]),
                     axial[active[i]]);
    const Vec f_axes = b.axes.transpose() * solution.point_force[i];
    st.push_back({stations_[active[i]].s, b.axes * g_axes, b.axes * b.compliance.cwiseProduct(f_axes)});
  }
  std::sort(st.begin(), st.end(), [](const StationState& x, const StationState& y) { return x.s < y.s; });
  return st;
}

std::vector<BandCoupling::Vec> BandCoupling::tissue_displacements(const std::vector<Vec>& points,
                                                                  std::vector<Vec> mesh_values,
                                                                  const std::vector<std::size_t>& active,
                                                                  const std::vector<double>& axial,
                                                                  const fem::Solution<3>& solution) const {
  const std::vector<StationState> st = station_states(active, axial, solution);
  if (st.empty() || effective_radius_ <= radius_) return mesh_values;
  const Vec entry = stations_.front().position - stations_.front().s * axis_;
  const double half = 0.5 * stations_.front().length, log_ratio = std::log(effective_radius_ / radius_);
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Vec d = points[k] - entry;
    const double t = d.dot(axis_), r = (d - t * axis_).norm();
    if (r >= effective_radius_ || t < st.front().s - half || t > st.back().s + half) continue;
    // The two station centres around t (the nearest one beyond the ends), weights linear in t.
    std::size_t hi = 0;
    while (hi < st.size() && st[hi].s < t) ++hi;
    const std::size_t lo = hi == 0 ? 0 : hi - 1;
    hi = std::min(hi, st.size() - 1);
    const double w = hi == lo ? 0.0 : (t - st[lo].s) / (st[hi].s - st[lo].s);
    const Vec g = (1 - w) * st[lo].g + w * st[hi].g, jump = (1 - w) * st[lo].jump + w * st[hi].jump;
    const double phi = std::log(effective_radius_ / std::max(r, radius_)) / log_ratio;
    mesh_values[k] = g - (1.0 - phi) * jump;  // ū + φ (g − ū)
  }
  return mesh_values;
}

}  // namespace vim::pipeline

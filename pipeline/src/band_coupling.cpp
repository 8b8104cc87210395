// The band coupling of a 3D needle of finite radius (needle_coupling.hpp, docs/needle-model.md).
#include <algorithm>
#include <cmath>
#include <set>
#include <vim/fem/needle_band.hpp>
#include <vim/pipeline/needle_coupling.hpp>

namespace vim::pipeline {

namespace {

// The edge of the cube of the cell's volume: (6V)^(1/3) for a tetrahedron (4 support vertices),
// V^(1/3) for a grid cell (the bounding box of its 8 vertices).
double cell_size(const fem::CellLocator<3>& locator, const std::vector<int>& support) {
  if (support.size() == 4) {
    Eigen::Matrix3d e;
    for (int k = 0; k < 3; ++k) e.col(k) = locator.vertex(support[k + 1]) - locator.vertex(support[0]);
    return std::cbrt(std::abs(e.determinant()));
  }
  Eigen::Vector3d lo = locator.vertex(support.front()), hi = lo;
  for (int v : support) lo = lo.cwiseMin(locator.vertex(v)), hi = hi.cwiseMax(locator.vertex(v));
  return std::cbrt((hi - lo).prod());
}

}  // namespace

double path_element_size(const fem::CellLocator<3>& locator, const Eigen::Vector3d& entry,
                         const Eigen::Vector3d& axis, double depth) {
  // Points every quarter of the mean edge: every cell the path crosses over more than that is seen. They
  // lie a thousandth of an edge off the path, so that a path along mesh edges or faces still finds
  // points inside cells (whose support is the whole cell).
  const double step = std::max(0.25 * locator.mean_edge_length(), 1e-6 * depth);
  const Eigen::Matrix3d frame = fem::needle_frame(axis);
  const Eigen::Vector3d off = 1e-3 * locator.mean_edge_length() * (0.54 * frame.col(0) + 0.84 * frame.col(1));
  std::set<long> seen;
  std::vector<int> support;
  double sum = 0.0;
  for (double s = 0.5 * step; s < depth; s += step) {
    const long c = locator.locate(entry + s * axis + off, &support);
    if (c < 0 || support.size() < 4 || !seen.insert(c).second) continue;
    sum += cell_size(locator, support);
  }
  return seen.empty() ? locator.mean_edge_length() : sum / static_cast<double>(seen.size());
}

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

}  // namespace vim::pipeline

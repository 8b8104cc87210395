// Element quality (paper §IV quality bound, §VI statistics): dihedral / interior angles,
// normalised radius ratio dim·r_in/R_circ, acceptability under a QualityBound, mesh summary.
#include <vim/quality.hpp>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>

namespace vim {

namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

inline double angle_deg(const Eigen::VectorXd& u, const Eigen::VectorXd& v) {
  const double nu = u.norm(), nv = v.norm();
  if (nu == 0.0 || nv == 0.0) return 0.0;
  const double c = std::clamp(u.dot(v) / (nu * nv), -1.0, 1.0);
  return std::acos(c) * kDeg;
}

// Measure of the facet opposite vertex i (length in 2D, area in 3D).
inline double facet_measure(const std::array<Eigen::Vector2d, 3>& x, int i) {
  return (x[(i + 2) % 3] - x[(i + 1) % 3]).norm();
}
inline double facet_measure(const std::array<Eigen::Vector3d, 4>& x, int i) {
  std::array<Eigen::Vector3d, 3> f;
  for (int k = 0, m = 0; k < 4; ++k)
    if (k != i) f[m++] = x[k];
  return 0.5 * (f[1] - f[0]).cross(f[2] - f[0]).norm();
}

}  // namespace

template <>
std::array<double, 3> dihedral_angles_deg<2>(const std::array<Eigen::Vector2d, 3>& x) {
  std::array<double, 3> a;
  for (int i = 0; i < 3; ++i) a[i] = angle_deg(x[(i + 1) % 3] - x[i], x[(i + 2) % 3] - x[i]);
  return a;
}

// Dihedral angle at edge (i,j): the angle between the two faces through it, measured inside the
// tetrahedron = angle between the components of x_k − x_i and x_l − x_i orthogonal to the edge.
template <>
std::array<double, 6> dihedral_angles_deg<3>(const std::array<Eigen::Vector3d, 4>& x) {
  static constexpr int edges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                      {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  std::array<double, 6> a;
  for (int e = 0; e < 6; ++e) {
    const int i = edges[e][0], j = edges[e][1], k = edges[e][2], l = edges[e][3];
    const Eigen::Vector3d t = x[j] - x[i];
    const double tt = t.squaredNorm();
    Eigen::Vector3d u = x[k] - x[i], v = x[l] - x[i];
    if (tt > 0.0) {
      u -= (u.dot(t) / tt) * t;
      v -= (v.dot(t) / tt) * t;
    }
    a[e] = angle_deg(u, v);
  }
  return a;
}

template <int dim>
double max_dihedral_deg(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  const auto a = dihedral_angles_deg<dim>(x);
  return *std::max_element(a.begin(), a.end());
}

template <int dim>
double min_dihedral_deg(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  const auto a = dihedral_angles_deg<dim>(x);
  return *std::min_element(a.begin(), a.end());
}

template <int dim>
double normalized_radius_ratio(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  const double vol = std::abs(signed_volume<dim>(x));
  if (!(vol > 0.0)) return 0.0;
  double facets = 0.0;
  for (int i = 0; i <= dim; ++i) facets += facet_measure(x, i);
  const double r_in = dim * vol / facets;  // vol = (1/dim) · r_in · Σ facets
  // Circumcentre c (relative to x_0): 2 (x_k − x_0)·c = |x_k − x_0|².
  Eigen::Matrix<double, dim, dim> m;
  Eigen::Matrix<double, dim, 1> rhs;
  for (int k = 0; k < dim; ++k) {
    const Eigen::Matrix<double, dim, 1> e = x[k + 1] - x[0];
    m.row(k) = 2.0 * e.transpose();
    rhs[k] = e.squaredNorm();
  }
  const double r_circ = m.fullPivLu().solve(rhs).norm();
  if (!(r_circ > 0.0) || !std::isfinite(r_circ)) return 0.0;
  return std::min(1.0, dim * r_in / r_circ);
}

template <int dim>
bool acceptable(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, const QualityBound& b) {
  double e = 0.0;
  for (int i = 0; i <= dim; ++i)
    for (int k = i + 1; k <= dim; ++k) e = std::max(e, (x[i] - x[k]).norm());
  if (!(signed_volume<dim>(x) > 1e-12 * std::pow(e, dim))) return false;
  const auto a = dihedral_angles_deg<dim>(x);
  const auto [lo, hi] = std::minmax_element(a.begin(), a.end());
  if (*hi > b.max_dihedral_deg) return false;
  if (b.min_dihedral_deg > 0.0 && *lo < b.min_dihedral_deg) return false;
  if (b.min_radius_ratio > 0.0 && normalized_radius_ratio<dim>(x) < b.min_radius_ratio) return false;
  return true;
}

template <int dim>
MeshQuality mesh_quality(const SimplexMesh<dim>& mesh) {
  MeshQuality q;
  q.min_dihedral_deg = std::numeric_limits<double>::infinity();
  q.max_dihedral_deg = 0.0;
  q.min_nrr = std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    if (!(signed_volume<dim>(x) > 0.0)) ++q.inverted;
    const auto a = dihedral_angles_deg<dim>(x);
    const auto [lo, hi] = std::minmax_element(a.begin(), a.end());
    q.min_dihedral_deg = std::min(q.min_dihedral_deg, *lo);
    q.max_dihedral_deg = std::max(q.max_dihedral_deg, *hi);
    q.min_nrr = std::min(q.min_nrr, normalized_radius_ratio<dim>(x));
  }
  if (mesh.n_cells() == 0) q.min_dihedral_deg = q.min_nrr = 0.0;
  return q;
}

#define VIM_QUALITY_INSTANTIATE(D)                                                                   \
  template double max_dihedral_deg<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&);       \
  template double min_dihedral_deg<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&);       \
  template double normalized_radius_ratio<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&); \
  template bool acceptable<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&, const QualityBound&); \
  template MeshQuality mesh_quality<D>(const SimplexMesh<D>&);
VIM_QUALITY_INSTANTIATE(2)
VIM_QUALITY_INSTANTIATE(3)
#undef VIM_QUALITY_INSTANTIATE

}  // namespace vim

// Element quality (paper §IV quality bound, §VI statistics): dihedral / interior angles,
// normalised radius ratio dim·r_in/R_circ, acceptability under a QualityBound, mesh summary.
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vim/quality.hpp>

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

// ---------------------------------------------------------------------------------------------
// QualityCheck: the fast decision of acceptable().

namespace {
// Cosines of the dihedral angles (3D: between outward facet normals n_i, n_j the angle at their
// shared edge has cos = −n_i·n_j / |n_i||n_j|) or interior angles (2D); no allocation, no acos.
// `fixed` (if given) holds the unoriented normal and length of the face opposite fixed->vertex,
// computed by the same expression, so the result is bit-identical.
inline int angle_cosines(const std::array<Eigen::Vector2d, 3>& x, std::array<double, 6>& c,
                         const FixedFace<2>* /*fixed*/) {
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d u = x[(i + 1) % 3] - x[i], v = x[(i + 2) % 3] - x[i];
    c[i] = u.dot(v) / std::sqrt(u.squaredNorm() * v.squaredNorm());
  }
  return 3;
}
// Unoriented normal (x_k − x_j)×(x_l − x_j), (j, k, l) = (i+1, i+2, i+3) mod 4, of the face opposite
// vertex i; the precomputed one if i is the fixed face's vertex (the same expression).
inline Eigen::Vector3d raw_face_normal(const std::array<Eigen::Vector3d, 4>& x, int i,
                                       const FixedFace<3>* fixed) {
  if (fixed && fixed->vertex == i) return fixed->normal;
  const int j = (i + 1) % 4, k = (i + 2) % 4, l = (i + 3) % 4;
  return (x[k] - x[j]).cross(x[l] - x[j]);
}
inline int angle_cosines(const std::array<Eigen::Vector3d, 4>& x, std::array<double, 6>& c,
                         const FixedFace<3>* fixed) {
  std::array<Eigen::Vector3d, 4> n;
  std::array<double, 4> len;
  for (int i = 0; i < 4; ++i) {
    const int j = (i + 1) % 4;
    const bool known = fixed && fixed->vertex == i;
    n[i] = raw_face_normal(x, i, fixed);
    if (n[i].dot(x[i] - x[j]) > 0.0) n[i] = -n[i];
    len[i] = known ? fixed->length : n[i].norm();
  }
  int m = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) c[m++] = -n[i].dot(n[j]) / (len[i] * len[j]);
  return 6;
}
}  // namespace

template <int dim>
FixedFace<dim> fixed_face(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, int vertex) {
  FixedFace<dim> f;
  f.vertex = vertex;
  if constexpr (dim == 3) {
    const int j = (vertex + 1) % 4, k = (vertex + 2) % 4, l = (vertex + 3) % 4;
    f.normal = (x[k] - x[j]).cross(x[l] - x[j]);
    f.length = f.normal.norm();
  }
  for (int i = 0; i <= dim; ++i)
    for (int k = i + 1; k <= dim; ++k)
      if (i != vertex && k != vertex) f.longest2 = std::max(f.longest2, (x[i] - x[k]).squaredNorm());
  return f;
}
template FixedFace<2> fixed_face<2>(const std::array<Eigen::Vector2d, 3>&, int);
template FixedFace<3> fixed_face<3>(const std::array<Eigen::Vector3d, 4>&, int);

namespace {
// The normalised radius ratio d·r_in/R_circ against `bound` from closed forms (circumcentre by
// Cramer's rule, facets by cross products): +1 clearly above, −1 clearly below, 0 too close to
// call or too flat for the closed form to be trusted (then vim::acceptable decides, with its own
// evaluation). The margin 1e-9 is far above the round-off of either evaluation for simplices
// with volume > 1e-4·longest^dim.
int ratio_side(const std::array<Eigen::Vector2d, 3>& x, double bound) {
  const Eigen::Vector2d a = x[1] - x[0], b = x[2] - x[0];
  const double det = a.x() * b.y() - a.y() * b.x();  // 2 · area
  const double la = a.norm(), lb = b.norm(), lc = (x[2] - x[1]).norm();
  const double longest = std::max({la, lb, lc});
  if (!(det > 1e-4 * longest * longest)) return 0;
  const double a2 = a.squaredNorm(), b2 = b.squaredNorm();
  const Eigen::Vector2d c((a2 * b.y() - b2 * a.y()) / (2.0 * det), (b2 * a.x() - a2 * b.x()) / (2.0 * det));
  const double nrr = 2.0 * (det / (la + lb + lc)) / c.norm();  // r_in = 2·area / perimeter
  return nrr > bound + 1e-9 ? 1 : nrr < bound - 1e-9 ? -1 : 0;
}
int ratio_side(const std::array<Eigen::Vector3d, 4>& x, double bound) {
  const Eigen::Vector3d a = x[1] - x[0], b = x[2] - x[0], c = x[3] - x[0];
  const Eigen::Vector3d bc = b.cross(c), ca = c.cross(a), ab = a.cross(b);
  const double det = a.dot(bc);  // 6 · volume
  double longest2 = std::max({a.squaredNorm(), b.squaredNorm(), c.squaredNorm(), (b - a).squaredNorm(),
                              (c - a).squaredNorm(), (c - b).squaredNorm()});
  if (!(det > 6e-4 * longest2 * std::sqrt(longest2))) return 0;
  const Eigen::Vector3d centre =
      (a.squaredNorm() * bc + b.squaredNorm() * ca + c.squaredNorm() * ab) / (2.0 * det);
  // Facet areas ×2: the faces opposite x_1, x_2, x_3 are spanned by (b, c), (c, a), (a, b).
  const double facets2 = bc.norm() + ca.norm() + ab.norm() + (c - a).cross(b - a).norm();
  const double nrr = 3.0 * (det / facets2) / centre.norm();  // r_in = 3V / Σ areas = det / Σ (2·areas)
  return nrr > bound + 1e-9 ? 1 : nrr < bound - 1e-9 ? -1 : 0;
}
}  // namespace

template <int dim>
QualityCheck<dim>::QualityCheck(const QualityBound& bound) : bound_(bound) {
  constexpr double kPi = 3.14159265358979323846;
  cos_max_ = std::cos(bound_.max_dihedral_deg * kPi / 180.0);
  cos_min_ = std::cos(bound_.min_dihedral_deg * kPi / 180.0);
  // The square-root-free test (3D) needs both thresholds of the max bound negative (bound well
  // above 90°) and no other bound.
  sqrt_free_ =
      dim == 3 && bound_.min_dihedral_deg <= 0.0 && bound_.min_radius_ratio <= 0.0 && cos_max_ + 1e-9 < 0.0;
  reject2_ = (cos_max_ - 1e-9) * (cos_max_ - 1e-9);
  defer2_ = (cos_max_ + 1e-9) * (cos_max_ + 1e-9);
}

template <int dim>
bool QualityCheck<dim>::operator()(const Simplex& x, double vol, const FixedFace<dim>* fixed) const {
  if (bound_.min_radius_ratio > 0.0) {
    // Clearly above the ratio bound: the angle bounds below decide (their deferral to
    // vim::acceptable checks the ratio again, exactly).
    const int side = vol > 0.0 ? ratio_side(x, bound_.min_radius_ratio) : -1;
    if (side < 0) return false;
    if (side == 0) return vim::acceptable<dim>(x, bound_);
  }
  // Longest edge (max is exact in any order, so the fixed face's edges may come precomputed).
  double longest2 = fixed ? fixed->longest2 : 0.0;
  for (int i = 0; i <= dim; ++i)
    for (int k = i + 1; k <= dim; ++k)
      if (!fixed || i == fixed->vertex || k == fixed->vertex)
        longest2 = std::max(longest2, (x[i] - x[k]).squaredNorm());
  if (!(vol > 0.0)) return false;
  const double scale = dim == 3 ? longest2 * std::sqrt(longest2) : longest2;  // longest^dim
  bool defer = !(vol > 2e-12 * scale);
  if (!defer && sqrt_free_) return sqrt_free_test(x, fixed);
  std::array<double, 6> c;
  const int m = angle_cosines(x, c, fixed);
  constexpr double eps = 1e-9;
  for (int i = 0; i < m; ++i) {
    if (!(c[i] >= cos_max_ - eps)) return false;  // angle clearly above the max bound (or NaN)
    if (c[i] < cos_max_ + eps) defer = true;
    if (bound_.min_dihedral_deg > 0.0) {
      if (c[i] > cos_min_ + eps) return false;
      if (c[i] > cos_min_ - eps) defer = true;
    }
  }
  return defer ? vim::acceptable<dim>(x, bound_) : true;
}

// The max-angle bound without square roots or divisions (3D, positive volume): the outward normal
// of the face opposite vertex i is (−1)^i (x_k − x_j)×(x_l − x_j); an angle's cosine
// c = −n_i·n_j / |n_i||n_j| is only below the (negative) thresholds when t = −n_i·n_j < 0, and then
// c < T ⇔ t² > T²·|n_i|²|n_j|². The thresholds keep the 1e-9 margin of the cosine path, far above
// the round-off of either evaluation, so both reach the decision of vim::acceptable.
template <int dim>
bool QualityCheck<dim>::sqrt_free_test(const Simplex& x, const FixedFace<dim>* fixed) const {
  if constexpr (dim == 3) {
    std::array<Eigen::Vector3d, 4> n;
    std::array<double, 4> len2;
    for (int i = 0; i < 4; ++i) {
      const bool known = fixed && fixed->vertex == i;
      n[i] = raw_face_normal(x, i, fixed);
      if (i & 1) n[i] = -n[i];
      len2[i] = known ? fixed->length * fixed->length : n[i].squaredNorm();
    }
    bool defer = false;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const double t = -n[i].dot(n[j]);
        if (t >= 0.0) continue;
        const double q = t * t, prod = len2[i] * len2[j];
        if (!(q <= reject2_ * prod)) return false;
        if (q > defer2_ * prod) defer = true;
      }
    return defer ? vim::acceptable<dim>(x, bound_) : true;
  } else {
    return vim::acceptable<dim>(x, bound_);  // not reached: sqrt_free_ is false in 2D
  }
}

template class QualityCheck<2>;
template class QualityCheck<3>;
#define VIM_QUALITY_INSTANTIATE(D)                                                                         \
  template double max_dihedral_deg<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&);              \
  template double min_dihedral_deg<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&);              \
  template double normalized_radius_ratio<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&);       \
  template bool acceptable<D>(const std::array<Eigen::Matrix<double, D, 1>, D + 1>&, const QualityBound&); \
  template MeshQuality mesh_quality<D>(const SimplexMesh<D>&);
VIM_QUALITY_INSTANTIATE(2)
VIM_QUALITY_INSTANTIATE(3)
#undef VIM_QUALITY_INSTANTIATE

}  // namespace vim

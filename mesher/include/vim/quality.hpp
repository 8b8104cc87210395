// Element quality measures for the quality bound of paper §IV (max dihedral angle 150° by default)
// and the statistics of §VI (min/max dihedral, normalised radius ratio): 3D dihedral angles,
// 2D interior angles, dim·r_in/R_circ, and a whole-mesh summary.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vim/simplex_mesh.hpp>

namespace vim {

// 3D: the 6 dihedral angles at edges (0,1),(0,2),(0,3),(1,2),(1,3),(2,3); 2D: the interior angles at
// vertices 0,1,2. Degrees; independent of orientation.
template <int dim>
std::array<double, dim == 3 ? 6 : 3> dihedral_angles_deg(
    const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x);
template <>
std::array<double, 3> dihedral_angles_deg<2>(const std::array<Eigen::Vector2d, 3>& x);
template <>
std::array<double, 6> dihedral_angles_deg<3>(const std::array<Eigen::Vector3d, 4>& x);

template <int dim>
double max_dihedral_deg(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x);
template <int dim>
double min_dihedral_deg(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x);

// dim · r_in / R_circ ∈ [0, 1]; 1 for the regular simplex, 0 for a degenerate one.
template <int dim>
double normalized_radius_ratio(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x);

struct QualityBound {
  double max_dihedral_deg = 150.0;
  double min_dihedral_deg = 0.0;  // 0 = off
  double min_radius_ratio = 0.0;  // 0 = off
};

// signed_volume > 1e-12·(longest edge)^dim and every enabled bound holds.
template <int dim>
bool acceptable(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, const QualityBound& b);

// What the quality test of a 1-ring element can reuse while one of its vertices moves: the face
// opposite that vertex (3D: its unoriented normal and length) and the longest of its edges.
template <int dim>
struct FixedFace {
  int vertex = -1;  // local index of the moving vertex
  Eigen::Matrix<double, dim, 1> normal = Eigen::Matrix<double, dim, 1>::Zero();
  double length = 0.0, longest2 = 0.0;
};
template <int dim>
FixedFace<dim> fixed_face(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, int vertex);

// acceptable() as the optimiser evaluates it for every candidate: decides from the angles' cosines
// (no acos; in 3D with only the max bound on, without square roots) when every angle is clearly
// (1e-9 in cosine) within the bound or one is clearly outside it, and from closed forms of the
// radius ratio likewise; otherwise it defers to acceptable(x, bound()). Its decision is always
// acceptable()'s: the margins are far above the round-off of either evaluation.
template <int dim>
class QualityCheck {
 public:
  using Simplex = std::array<Eigen::Matrix<double, dim, 1>, dim + 1>;

  QualityCheck() : QualityCheck(QualityBound{}) {}
  explicit QualityCheck(const QualityBound& bound);
  const QualityBound& bound() const { return bound_; }

  // acceptable(x, bound()) for x of signed volume `volume`; `fixed` (optional): fixed_face(x, i) of
  // the vertex i that moves (bit-identical result, less work).
  bool operator()(const Simplex& x, double volume, const FixedFace<dim>* fixed = nullptr) const;

 private:
  bool sqrt_free_test(const Simplex& x, const FixedFace<dim>* fixed) const;

  QualityBound bound_;
  double cos_max_ = -1.0, cos_min_ = 1.0;  // cosines of the dihedral bounds
  bool sqrt_free_ = false;                 // the squared-cosine test applies (3D only)
  double reject2_ = 1.0, defer2_ = 1.0;    // (cos_max_ ∓ 1e-9)²
};

extern template class QualityCheck<2>;
extern template class QualityCheck<3>;

struct MeshQuality {
  double min_dihedral_deg = 0.0, max_dihedral_deg = 0.0, min_nrr = 0.0;
  long inverted = 0;  // cells with signed volume <= 0
};

template <int dim>
MeshQuality mesh_quality(const SimplexMesh<dim>& mesh);

}  // namespace vim

// Element quality measures for the quality bound of paper §IV (max dihedral angle 150° by default)
// and the statistics of §VI (min/max dihedral, normalised radius ratio): 3D dihedral angles,
// 2D interior angles, dim·r_in/R_circ, and a whole-mesh summary.
#pragma once

#include <vim/simplex_mesh.hpp>

#include <Eigen/Core>

#include <array>

namespace vim {

// 3D: the 6 dihedral angles at edges (0,1),(0,2),(0,3),(1,2),(1,3),(2,3); 2D: the interior angles at
// vertices 0,1,2. Degrees; independent of orientation.
template <int dim>
std::array<double, dim == 3 ? 6 : 3> dihedral_angles_deg(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x);
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

struct MeshQuality {
  double min_dihedral_deg = 0.0, max_dihedral_deg = 0.0, min_nrr = 0.0;
  long inverted = 0;  // cells with signed volume <= 0
};

template <int dim>
MeshQuality mesh_quality(const SimplexMesh<dim>& mesh);

}  // namespace vim

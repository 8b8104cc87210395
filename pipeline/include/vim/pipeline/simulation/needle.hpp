// Needle geometry for the kinematic insertion model: sampling the embedded shaft points along the
// straight path (docs/architecture.md; points located with fem::CellLocator), and the axial stiffness map of
// the embedded points, which the stick-slip and force models use for force control.
#pragma once

#include <Eigen/Core>
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <functional>
#include <vector>
#include <vim/fem/cell_locator.hpp>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim::pipeline {

// The project's point locator (simplex meshes and voxel grids), shared with the elastic model.
template <int dim>
using CellLocator = fem::CellLocator<dim>;

// One embedded shaft point: reference (frame) position entry + s·axis and the length of shaft it stands for.
template <int dim>
struct ShaftPoint {
  Eigen::Matrix<double, dim, 1> position;
  double s = 0.0;
  double length = 0.0;
};

// Shaft points at s = 0, pitch, 2·pitch, … < depth, keeping a candidate only if the vertices of its
// support that are not `blocked` (fully fixed by a Dirichlet condition) are not empty and neither equal
// nor a subset of the previous kept point's (at most one point per cell crossed, so the constraints stay
// linearly independent, also where the path enters a held region).
// snap_to_vertices: a candidate whose support lies on the path's line (the path runs along mesh edges)
// is replaced by those vertices at their own arc lengths. Points inside a chain of collinear edges can
// make nearly dependent constraints (condition number > 1e10 along a 2D box edge); the simulation
// re-samples with it when the solve reports that (fem::DependentPointConstraints).
template <int dim>
std::vector<ShaftPoint<dim>> sample_shaft(const CellLocator<dim>& locator,
                                          const Eigen::Matrix<double, dim, 1>& entry,
                                          const Eigen::Matrix<double, dim, 1>& axis, double depth,
                                          double pitch, const std::vector<bool>& blocked,
                                          bool snap_to_vertices = false);

// The affine map from the axial values w of a fixed set of m point constraints to their axial forces,
// f = K w + c (the condensed stiffness of the embedded points along the needle; K is symmetric positive
// definite). probe() measures it with m + 1 model solves (w = 0, then w = sigma·e_j); afterwards force
// control (stick-slip, force model) is dense m×m algebra instead of one model solve per iteration.
struct AxialMap {
  Eigen::MatrixXd K;
  Eigen::VectorXd c;
  static AxialMap probe(Eigen::Index m, const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& forces,
                        double sigma);
  Eigen::VectorXd operator()(const Eigen::VectorXd& w) const { return K * w + c; }
  // Sets the free entries of w so that the forces there equal target (the other entries are kept).
  void solve_free(Eigen::VectorXd& w, const std::vector<bool>& free, const Eigen::VectorXd& target) const;
};

// A straight needle path in frame coordinates: the segment from `entry` to `entry + depth·axis`.
template <int dim>
struct NeedlePath {
  Eigen::Matrix<double, dim, 1> entry, axis;  // axis of unit length
  double depth = 0.0;
  double distance(const Eigen::Matrix<double, dim, 1>& p) const {
    const double s = std::clamp((p - entry).dot(axis), 0.0, depth);
    return (p - entry - s * axis).norm();
  }
};

// Mesh density for needle-path refinement (paper §VI-E sizing), on the grid of `like` (frame
// coordinates): ρ(x) = 1 + (ρ_max − 1)·exp(−(d(x)/radius)²), d = distance to the nearest path,
// ρ_max = size_ratio^−(dim+2). Weighting E_G by ρ makes the optimal element size (where the image
// is uniform) ∝ ρ^(−1/(dim+2)), so elements on a path are about size_ratio times the size of elements
// far from every path. Throws std::invalid_argument unless 0 < size_ratio <= 1, radius > 0 and
// there is at least one path.
template <int dim>
Image<dim> needle_density(const Image<dim>& like, const std::vector<NeedlePath<dim>>& paths,
                          double size_ratio, double radius);

}  // namespace vim::pipeline

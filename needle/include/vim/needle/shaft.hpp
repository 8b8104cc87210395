// The embedded shaft points of a straight needle: sampling the shaft along its path (docs/architecture.md,
// the needle model; points located with fem::CellLocator, so simplex meshes and voxel grids alike).
#pragma once

#include <Eigen/Core>
#include <vector>
#include <vim/needle/fem_types.hpp>

namespace vim::needle {

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

}  // namespace vim::needle

// The initial mesh of VIM (paper §IV-C, §VI): a regular grid over the image box with the
// Kuhn/Freudenthal subdivision (2 triangles per square, 6 tetrahedra per cube sharing the main
// diagonal; max dihedral 90° on cubes), node counts from a node budget or a spacing.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>
#include <vim/simplex_mesh.hpp>

namespace vim {

// Nodes per axis giving ≈ cubic cells with the largest node count ≤ node_budget (125 on a cube →
// 5×5×5); each axis ≥ 2. Throws std::invalid_argument if node_budget < 2^dim or the box is empty.
template <int dim>
std::array<int, dim> nodes_per_axis_for_budget(const Eigen::Matrix<double, dim, 1>& box_min,
                                               const Eigen::Matrix<double, dim, 1>& box_max,
                                               long node_budget);

// Nodes per axis for cells of edge ≈ spacing (rounded; each axis ≥ 2). Throws if spacing <= 0 or
// the grid would have more nodes than int ids can index (a tiny spacing).
template <int dim>
std::array<int, dim> nodes_per_axis_for_spacing(const Eigen::Matrix<double, dim, 1>& box_min,
                                                const Eigen::Matrix<double, dim, 1>& box_max, double spacing);

// Conforming Kuhn/Freudenthal mesh of the box, all cells positively oriented; node (i_0,...,i_{d-1})
// has number i_0 + n_0·(i_1 + n_1·i_2) (axis 0 fastest).
template <int dim>
SimplexMesh<dim> regular_grid_mesh(const Eigen::Matrix<double, dim, 1>& box_min,
                                   const Eigen::Matrix<double, dim, 1>& box_max,
                                   const std::array<int, dim>& nodes_per_axis);

// Per node: the number of box faces it lies on within tol (0 interior, 1 face, ..., dim corner).
template <int dim>
std::vector<std::uint8_t> boundary_kind(const SimplexMesh<dim>& mesh,
                                        const Eigen::Matrix<double, dim, 1>& box_min,
                                        const Eigen::Matrix<double, dim, 1>& box_max, double tol);

}  // namespace vim

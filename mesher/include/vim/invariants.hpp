// Mesh invariants of a VIM optimisation (paper §IV): what every node update, swap and insertion must
// preserve. VimOptimizer::check_invariants() checks them all after each stage when
// VimOptions::check_invariants is on; a checked build (cmake -DVIM_CHECKED=ON) turns it on by
// default, and `vim-pipeline --check-invariants` turns it on for one run.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/quality.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim {

// Thrown by VimOptimizer::check_invariants; what() names the stage, the iteration and the first
// violated invariant (cell or node index and the offending value).
class InvariantViolation : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// The geometric invariants of a mesh of the box [box_min, box_max], checked from scratch:
//  - every node lies in the box (within tol); a node whose fixed_axes bit a is set lies on the box
//    face x_a = box_min[a] or box_max[a] (within tol);
//  - every live cell has dim+1 distinct valid vertex indices, positive volume and satisfies the
//    quality bound (angles within slack_deg of the bounds; radius ratio within 1e-9);
//  - conformity: each facet of a live cell is shared by at most two live cells, and a facet of
//    only one cell lies on a box face; the live volumes sum to the box volume (relative 1e-9).
// Together these mean the live cells tile the box without overlap or inversion.
// alive: empty = all cells live. fixed_axes: empty = no face constraints checked.
// Returns "" when all hold, else a description of the first violation.
template <int dim>
std::string mesh_invariant_violation(const SimplexMesh<dim>& mesh, const std::vector<char>& alive,
                                     const std::vector<std::uint8_t>& fixed_axes,
                                     const Eigen::Matrix<double, dim, 1>& box_min,
                                     const Eigen::Matrix<double, dim, 1>& box_max, double tol,
                                     const QualityBound& bound, double slack_deg = 1e-6);

}  // namespace vim

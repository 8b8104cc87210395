// Internal to vim_fem, deal.II-free: the checks the input of an elastic model passes — the simplex mesh,
// the voxel grid, the moduli and the Poisson ratio before the model is built (std::invalid_argument
// naming what is wrong and what would be valid), and the Dirichlet conditions once they are applied.
#pragma once

#include <mpi.h>

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>
#include <vim/fem/conditions.hpp>
#include <vim/fem/model.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim::fem {

// ν in (-1, 0.5).
void check_poisson_ratio(double nu);

// One finite modulus > 0 per cell; `what` names the caller in the message.
void check_moduli(const std::vector<double>& E, std::size_t n_cells, const char* what);

// At least one cell per axis and a finite, non-empty box.
template <int dim>
void check_voxel_grid(const std::array<long, dim>& cells, const Vec<dim>& box_min, const Vec<dim>& box_max);

// Rejects (std::invalid_argument, naming the cell) meshes without cells, non-finite vertices, cells
// referring to missing vertices, degenerate cells (|volume| tiny against the longest edge), facets
// shared by more than two cells, and inverted cells: two cells sharing a facet whose opposite vertices
// lie on the SAME side of it overlap (a tangled mesh). A mesh whose cells are merely listed with the
// other orientation is fine: deal.II's invert_cells_with_negative_measure reorders those.
template <int dim>
void check_simplex_mesh(const SimplexMesh<dim>& mesh);

// A volume support's base (VolumeSupport::base): empty or one finite displacement per point; `where`
// names the caller in the message.
template <int dim>
void check_support_base(const std::vector<Vec<dim>>& base, std::size_t n_points, const std::string& where);

// Directions held by the Dirichlet conditions: (support point, unit direction) per held direction.
template <int dim>
using ConstrainedDirections = std::vector<std::pair<Vec<dim>, Vec<dim>>>;

// Throws unless the constrained directions (this rank's share, summed over `comm`) remove every rigid
// motion of the body with these vertices: std::runtime_error if nothing is held (naming the regions
// of `bcs`), SingularConstraints if a rigid motion stays free.
template <int dim>
void check_rigid_modes_removed(const ConstrainedDirections<dim>& constrained,
                               const std::vector<Vec<dim>>& vertices,
                               const std::vector<DirichletBC<dim>>& bcs, MPI_Comm comm);

}  // namespace vim::fem

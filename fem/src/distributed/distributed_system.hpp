// Internal to vim_fem: the distributed system of an MPI solve (distributed.cpp), the part of a simplex
// mesh a rank builds for it (simplex_part.cpp) and the matrix-free geometric multigrid solve of 3D
// voxel models on it (distributed_mg.cpp).
#pragma once

#include <deal.II/distributed/tria_base.h>
#include <deal.II/grid/tria_description.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <memory>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "model_state.hpp"
#include "mumps_factor.hpp"

namespace vim::fem {

template <int dim>
using State = ModelAccess::State<dim>;

// The distributed mesh, DoFs, Dirichlet constraints and assembled system of one solve (K stays empty
// when the solve is matrix-free).
template <int dim>
struct DistributedSystem {
  std::unique_ptr<dealii::parallel::TriangulationBase<dim>> tria;
  // simplex models: the input vertex index of each vertex of `tria` (the rank's part of the mesh)
  std::vector<unsigned> serial_vertex;
  dealii::DoFHandler<dim> dof;
  dealii::IndexSet owned, relevant;
  // per relevant DoF (position in `relevant`): support point and component
  std::vector<dealii::Point<dim>> rel_point;
  std::vector<unsigned char> rel_comp;
  dealii::AffineConstraints<double> constraints;
  std::unordered_map<dealii::types::global_dof_index, int> dof_bc;  // Dirichlet DoF -> its condition
  dealii::TrilinosWrappers::SparseMatrix K;
  dealii::TrilinosWrappers::MPI::Vector f;
};

// One rank's part of a simplex mesh for a parallel::fullydistributed::Triangulation.
template <int dim>
struct SimplexPart {
  // The rank's cells and the cells sharing a vertex with them (ghosts), each a coarse cell whose id
  // is its serial cell index, with its material id (the input cell index) and boundary ids.
  dealii::TriangulationDescription::Description<dim, dim> description;
  // per vertex of the description: its index among the input vertices (ascending)
  std::vector<unsigned> serial_vertex;
};

// The owning rank of each of `cells` (positively oriented simplices over `vertices`) among n_ranks, the
// same on every rank: METIS on the cells' face graph; blocks of consecutive cells when METIS would
// leave a rank without cells. Throws std::invalid_argument if there are fewer cells than ranks.
template <int dim>
std::vector<unsigned> partition_cells(const std::vector<Vec<dim>>& vertices,
                                      const std::vector<std::array<int, dim + 1>>& cells, unsigned n_ranks);

// The part of the mesh of `cells` (positively oriented simplices over `vertices`) that the calling rank
// of `comm` builds, its cells those partition_cells gives it (identically on every rank, so no
// communication is needed).
template <int dim>
SimplexPart<dim> simplex_part(const std::vector<Vec<dim>>& vertices,
                              const std::vector<std::array<int, dim + 1>>& cells, MPI_Comm comm);

// u = A⁻¹ b by CG preconditioned with `preconditioner`, from u, to opt.tolerance relative to |b| (b = 0:
// u is left as it is); fills the iterations and relative residual of `stats`. Throws
// std::runtime_error naming `method` (the preconditioner, for the message) if CG does not converge.
template <class Matrix, class Vector, class Preconditioner>
void solve_cg_to_tolerance(const Matrix& A, Vector& u, const Vector& b, const Preconditioner& preconditioner,
                           const SolverOptions& opt, SolverStats& stats, const char* method) {
  const double bn = b.l2_norm();
  stats.iterations = 0;
  stats.residual = 0.0;
  if (!(bn > 0.0)) return;
  dealii::SolverControl control(opt.max_iterations, opt.tolerance * bn);
  dealii::SolverCG<Vector> cg(control);
  try {
    cg.solve(A, u, b, preconditioner);
  } catch (const dealii::SolverControl::NoConvergence& e) {
    std::ostringstream s;
    s << "solve_distributed: " << method << " did not converge in " << e.last_step
      << " iterations (relative residual " << e.last_residual / bn << ", tolerance " << opt.tolerance << ")";
    throw std::runtime_error(s.str());
  }
  stats.iterations = control.last_step();
  stats.residual = control.last_value() / bn;
}

// Whether a voxel model's distributed solve can be matrix-free multigrid: 3D, and every Dirichlet
// condition holds DoFs along the model's axes (constraint lines u_i = value, no oblique axes).
bool voxel_multigrid_applies(const State<3>& m, const DistributedSystem<3>& sys);

// u = K⁻¹ f on the p4est voxel grid of `sys` (built with its multigrid hierarchy and level DoFs), by CG
// preconditioned with a matrix-free geometric multigrid V-cycle (Chebyshev smoothing, per-cell Lamé
// parameters; coarse cells take the mean modulus of their voxels). `sys.f` is the assembled load with
// the Dirichlet values moved to the right-hand side; the result's constrained entries are zero (the
// caller distributes the constraints). Fills iterations, residual and precondition_seconds of stats.
dealii::TrilinosWrappers::MPI::Vector solve_voxel_multigrid(const State<3>& m,
                                                            const DistributedSystem<3>& sys,
                                                            const SolverOptions& opt, MPI_Comm comm,
                                                            SolverStats& stats);

// MUMPS's copy (not yet analysed) of the rows of K this rank owns, `owned` one range of rows. Collective.
inline std::unique_ptr<MumpsFactor> mumps_of(const dealii::TrilinosWrappers::SparseMatrix& K,
                                             const dealii::IndexSet& owned, MPI_Comm comm) {
  // Epetra's own row copies: deal.II's row iterators search for the next stored row from K.end(i),
  // which on a rank's last rows runs over the whole matrix (minutes at 128k DoFs).
  const Epetra_CrsMatrix& A = K.trilinos_matrix();
  std::vector<long> row_ptr{0}, columns;
  std::vector<double> values, row_values;
  std::vector<dealii::TrilinosWrappers::types::int_type> row_columns;
  for (const auto i : owned) {
    const auto row = static_cast<dealii::TrilinosWrappers::types::int_type>(i);
    const int length = A.NumGlobalEntries(row);
    row_values.resize(static_cast<std::size_t>(length));
    row_columns.resize(static_cast<std::size_t>(length));
    int got = 0;
    if (A.ExtractGlobalRowCopy(row, length, got, row_values.data(), row_columns.data()) != 0)
      throw std::logic_error("mumps_of: row " + std::to_string(i) + " is not stored on this rank");
    for (int k = 0; k < got; ++k)
      columns.push_back(static_cast<long>(row_columns[static_cast<std::size_t>(k)])),
          values.push_back(row_values[static_cast<std::size_t>(k)]);
    row_ptr.push_back(static_cast<long>(columns.size()));
  }
  const long first = owned.n_elements() ? static_cast<long>(*owned.begin()) : 0;
  return std::make_unique<MumpsFactor>(comm, static_cast<long>(K.m()), first, row_ptr, columns, values);
}

}  // namespace vim::fem

// The elastic model solved over MPI ranks. The only fem header that includes <mpi.h>.
#pragma once

#include <mpi.h>

#include <vim/fem/model.hpp>

namespace vim::fem {

// Solves `model` over `comm`: simplex models on a parallel::fullydistributed::Triangulation of the
// rank's part of the mesh (METIS partition of the cells, the same on every rank, plus the ghost cells
// around it) with Trilinos CG + AMG with rigid-body modes; voxel models on a
// p4est parallel::distributed::Triangulation built from the grid description, so a rank holds only its
// part (a voxel model's serial mesh is built only if solve()/solve_monolithic()/strain_energy_of() is
// used), in 3D with CG preconditioned by a matrix-free geometric multigrid over the grid's refinement
// levels (no matrix is stored) when every Dirichlet condition holds DoFs along the model's axes, else
// CG + AMG. Collective: every rank must hold the same model (same mesh, moduli, conditions) and call it.
// Every rank gets the full vertex_displacement, per-cell fields, strain energy and reactions. Point
// constraints and volume supports are not supported here (see distribute_solves). With more than
// one rank, OpenBLAS, OpenMP and deal.II's TBB run one thread per rank during the call (their worker
// threads otherwise spin on the cores the other ranks need); the previous limits are restored on return.
template <int dim>
Solution<dim> solve_distributed(ElasticModel<dim>& model, MPI_Comm comm, const SolverOptions& options = {});

// Makes the model's solve() and precompute() collective over `comm`: without point constraints a voxel
// model's solve() is solve_distributed (also on one rank: the matrix-free multigrid without a serial
// mesh); otherwise, with more than one rank, every rank holds the serial mesh and DoF numbering (for
// the constraint rows, sampling and the gathered fields) but no serial matrix: each K⁻¹ — the load's
// u0 and every compliance column K⁻¹cᵀ of a point-constraint row — is one CG + AMG solve on the
// distributed system (kept across calls), gathered to every rank, and the fields of a solution
// (strain, stress, energy, reactions) are computed by each rank on its own cells of that system. The
// Schur step over the rows is the serial one, done alike on every rank. Every rank must build the same
// model and make the same calls. Volume supports are refused (std::invalid_argument). The solver
// options' type is ignored (always CG + AMG); solve_monolithic() assembles the serial matrices.
template <int dim>
void distribute_solves(ElasticModel<dim>& model, MPI_Comm comm);

// The cells the calling rank of `comm` owns in the model's distributed solves, ascending: input cell
// indices of a simplex model (METIS partition), voxel indices of a voxel model (p4est partition); the
// ranks' lists together hold every cell once. Taken from the last distributed solve over as many
// ranks; before one, collective: the distributed mesh is built for it.
template <int dim>
std::vector<std::size_t> owned_cells(const ElasticModel<dim>& model, MPI_Comm comm);

}  // namespace vim::fem

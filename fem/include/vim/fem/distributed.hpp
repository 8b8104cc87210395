// The elastic model solved over MPI ranks. The only fem header that includes <mpi.h>.
#pragma once

#include <mpi.h>

#include <vim/fem/model.hpp>

namespace vim::fem {

// Solves `model` over `comm` with Trilinos CG + AMG with rigid-body modes: simplex models on a
// METIS-partitioned parallel::shared::Triangulation (every rank holds the whole mesh); voxel models on a
// p4est parallel::distributed::Triangulation built from the grid description, so a rank holds only its
// part (a voxel model's serial mesh is built only if solve()/solve_monolithic()/strain_energy_of() is
// used). Collective: every rank must hold the same model (same mesh, moduli, conditions) and call it.
// Every rank gets the full vertex_displacement, per-cell fields, strain energy and reactions. Point
// constraints and volume supports are not supported here (use ElasticModel::solve()). With more than
// one rank, OpenBLAS, OpenMP and deal.II's TBB run one thread per rank during the call (their worker
// threads otherwise spin on the cores the other ranks need); the previous limits are restored on return.
template <int dim>
Solution<dim> solve_distributed(ElasticModel<dim>& model, MPI_Comm comm, const SolverOptions& options = {});

}  // namespace vim::fem

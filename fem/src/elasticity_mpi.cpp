// MPI solve on parallel::fullydistributed::Triangulation (stub, being implemented).
#include "elasticity_impl.hpp"

namespace vim::fem {
template <int dim>
Solution<dim> ElasticModel<dim>::solve_distributed(MPI_Comm, const SolverOptions&) {
  throw std::runtime_error("solve_distributed: not implemented yet");
}
template Solution<2> ElasticModel<2>::solve_distributed(MPI_Comm, const SolverOptions&);
template Solution<3> ElasticModel<3>::solve_distributed(MPI_Comm, const SolverOptions&);
}  // namespace vim::fem

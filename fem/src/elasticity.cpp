// TEMPORARY skeleton: replaced by the deal.II implementation shortly.
#include <vim/fem/elasticity.hpp>

#include <stdexcept>

namespace vim::fem {

template <int dim>
struct ElasticModel<dim>::Impl {
  std::vector<Vec<dim>> vertices;
  std::vector<double> E;
  double nu = 0.3;
  unsigned degree = 1;
};

namespace {
[[noreturn]] void nyi(const char* what) { throw std::runtime_error(std::string("vim::fem: not implemented yet: ") + what); }
}  // namespace

template <int dim> ElasticModel<dim>::ElasticModel() : impl_(std::make_unique<Impl>()) {}
template <int dim>
ElasticModel<dim>::ElasticModel(const SimplexMesh<dim>& mesh, std::vector<double> E, double nu, unsigned degree)
    : impl_(std::make_unique<Impl>()) {
  for (const auto& p : mesh.points) impl_->vertices.push_back(p);
  impl_->E = std::move(E);
  impl_->nu = nu;
  impl_->degree = degree;
}
template <int dim>
ElasticModel<dim> ElasticModel<dim>::voxel_grid(const std::array<long, dim>&, const Vec<dim>&, const Vec<dim>&,
                                                std::vector<double>, double) { nyi("voxel_grid"); }
template <int dim> ElasticModel<dim>::~ElasticModel() = default;
template <int dim> ElasticModel<dim>::ElasticModel(ElasticModel&&) noexcept = default;
template <int dim> ElasticModel<dim>& ElasticModel<dim>::operator=(ElasticModel&&) noexcept = default;
template <int dim> void ElasticModel<dim>::add_dirichlet(const DirichletBC<dim>&) {}
template <int dim> void ElasticModel<dim>::add_surface_load(const SurfaceLoad<dim>&) {}
template <int dim> void ElasticModel<dim>::set_body_force(const Vec<dim>&) {}
template <int dim> unsigned ElasticModel<dim>::n_dofs() const { return 0; }
template <int dim> unsigned ElasticModel<dim>::n_cells() const { return 0; }
template <int dim> const std::vector<Vec<dim>>& ElasticModel<dim>::vertices() const { return impl_->vertices; }
template <int dim>
Solution<dim> ElasticModel<dim>::solve(const std::vector<PointConstraint<dim>>&, const SolverOptions&) { nyi("solve"); }
template <int dim>
Solution<dim> ElasticModel<dim>::solve_monolithic(const std::vector<PointConstraint<dim>>&, const SolverOptions&) { nyi("solve_monolithic"); }
template <int dim>
Solution<dim> ElasticModel<dim>::solve_distributed(MPI_Comm, const SolverOptions&) { nyi("solve_distributed"); }
template <int dim>
std::vector<Vec<dim>> ElasticModel<dim>::sample(const std::vector<Vec<dim>>&, PointSample*) const { nyi("sample"); }
template <int dim> double ElasticModel<dim>::strain_energy_of(const std::vector<Vec<dim>>&) const { nyi("strain_energy_of"); }
template <int dim> const std::vector<double>& ElasticModel<dim>::youngs_modulus() const { return impl_->E; }
template <int dim> double ElasticModel<dim>::poisson_ratio() const { return impl_->nu; }
template <int dim> unsigned ElasticModel<dim>::degree() const { return impl_->degree; }

template class ElasticModel<2>;
template class ElasticModel<3>;

}  // namespace vim::fem

// The matrix-free geometric multigrid solve of 3D voxel models over MPI ranks (distributed_system.hpp),
// after deal.II's step-37, for vector-valued linear elasticity with the material's constants per cell
// (fem/src/linear_elastic_material.hpp): no matrix
// is stored (the 128³ voxel grid, 6.3 M DoFs, needs about 19 GB as a Trilinos matrix with its AMG
// hierarchy), the operator is applied cell by cell with sum factorisation, and the p4est grid's
// refinement levels carry the multigrid hierarchy. Levels run in single precision (the preconditioner),
// the outer CG in double.
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/diagonal_matrix.h>
#include <deal.II/lac/la_parallel_vector.h>
#include <deal.II/lac/precondition.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/matrix_free/fe_evaluation.h>
#include <deal.II/matrix_free/matrix_free.h>
#include <deal.II/matrix_free/operators.h>
#include <deal.II/matrix_free/tools.h>
#include <deal.II/multigrid/mg_coarse.h>
#include <deal.II/multigrid/mg_constrained_dofs.h>
#include <deal.II/multigrid/mg_matrix.h>
#include <deal.II/multigrid/mg_smoother.h>
#include <deal.II/multigrid/mg_tools.h>
#include <deal.II/multigrid/mg_transfer_matrix_free.h>
#include <deal.II/multigrid/multigrid.h>

#include <sstream>
#include <stdexcept>

#include "distributed_system.hpp"
#include "linear_elastic_material.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

constexpr int kDim = 3;

// −∇·σ(u) with the material's stress law σ(ε(u)), Q1 (two Gauss points per axis), its constants per cell.
template <typename Number>
class ElasticityOperator
    : public MatrixFreeOperators::Base<kDim, LinearAlgebra::distributed::Vector<Number>> {
 public:
  using VectorType = LinearAlgebra::distributed::Vector<Number>;
  using Integrator = FEEvaluation<kDim, 1, 2, kDim, Number>;

  // The material's constants of every cell batch of the operator's MatrixFree from the mean modulus of
  // the voxels each cell covers (one voxel on the finest level).
  void set_material(const State<kDim>& m) {
    const MatrixFree<kDim, Number>& mf = *this->data;
    const auto material = m.material();
    law_.resize(mf.n_cell_batches());
    for (unsigned b = 0; b < mf.n_cell_batches(); ++b) {
      law_[b] = Lame<VectorizedArray<Number>>{VectorizedArray<Number>(0), VectorizedArray<Number>(0)};
      for (unsigned lane = 0; lane < mf.n_active_entries_per_cell_batch(b); ++lane)
        law_[b].set_lane(lane, material.of_modulus(mean_modulus(m, mf.get_cell_iterator(b, lane))));
    }
  }

  void compute_diagonal() override {
    this->inverse_diagonal_entries.reset(new DiagonalMatrix<VectorType>());
    VectorType& d = this->inverse_diagonal_entries->get_vector();
    this->data->initialize_dof_vector(d);
    MatrixFreeTools::compute_diagonal(*this->data, d, &ElasticityOperator::cell_kernel, this);
    this->set_constrained_entries_to_one(d);
    for (unsigned i = 0; i < d.locally_owned_size(); ++i) d.local_element(i) = Number(1) / d.local_element(i);
  }

 private:
  void apply_add(VectorType& dst, const VectorType& src) const override {
    this->data->cell_loop(&ElasticityOperator::local_apply, this, dst, src);
  }

  void local_apply(const MatrixFree<kDim, Number>& mf, VectorType& dst, const VectorType& src,
                   const std::pair<unsigned, unsigned>& range) const {
    Integrator phi(mf);
    for (unsigned cell = range.first; cell < range.second; ++cell) {
      phi.reinit(cell);
      phi.read_dof_values(src);
      cell_kernel(phi);
      phi.distribute_local_to_global(dst);
    }
  }

  // Gradients of the cell's values to the integrated stress (the values are read, the result written
  // by the caller).
  void cell_kernel(Integrator& phi) const {
    const unsigned cell = phi.get_current_cell_index();
    const Lame<VectorizedArray<Number>>& law = law_[cell];
    phi.evaluate(EvaluationFlags::gradients);
    for (unsigned q = 0; q < phi.n_q_points; ++q)
      phi.submit_symmetric_gradient(
          LinearElasticMaterial<kDim>::stress(law, phi.get_symmetric_gradient(q), phi.get_divergence(q)), q);
    phi.integrate(EvaluationFlags::gradients);
  }

  // Mean modulus of the voxels inside the (axis-aligned) cell.
  static double mean_modulus(const State<kDim>& m, const typename DoFHandler<kDim>::cell_iterator& cell) {
    std::array<long, kDim> lo{}, hi{};
    for (int d = 0; d < kDim; ++d) {
      const double h = (m.grid_max[d] - m.grid_min[d]) / m.grid_cells[d];
      lo[d] = std::lround((cell->vertex(0)[d] - m.grid_min[d]) / h);
      hi[d] = std::lround((cell->vertex(GeometryInfo<kDim>::vertices_per_cell - 1)[d] - m.grid_min[d]) / h);
    }
    double sum = 0.0;
    long n = 0;
    for (long k = lo[2]; k < hi[2]; ++k)
      for (long j = lo[1]; j < hi[1]; ++j)
        for (long i = lo[0]; i < hi[0]; ++i, ++n)
          sum += m.E[static_cast<std::size_t>(i + m.grid_cells[0] * (j + m.grid_cells[1] * k))];
    return n > 0 ? sum / static_cast<double>(n) : m.E[m.voxel_index(cell->center())];
  }

  AlignedVector<Lame<VectorizedArray<Number>>> law_;
};

using LevelVector = LinearAlgebra::distributed::Vector<float>;
using LevelOperator = ElasticityOperator<float>;

// The level DoFs that the model's Dirichlet conditions hold (a level vertex is held where a fine
// vertex at its place would be), per level.
void add_level_boundary_indices(const State<kDim>& m, const DoFHandler<kDim>& dof, MGConstrainedDoFs& mg) {
  const auto hold = [](types::global_dof_index, int) {};
  for (unsigned level = 0; level < dof.get_triangulation().n_global_levels(); ++level) {
    AffineConstraints<double> held;
    std::array<types::global_dof_index, kDim> group{};
    for (const auto& cell : dof.cell_iterators_on_level(level)) {
      if (cell->level_subdomain_id() == numbers::artificial_subdomain_id) continue;
      for (const unsigned v : cell->vertex_indices()) {
        for (unsigned c = 0; c < unsigned(kDim); ++c) group[c] = cell->mg_vertex_dof_index(level, v, c);
        if (!held.is_constrained(group[0])) m.constrain_point(cell->vertex(v), group, held, hold, nullptr);
      }
    }
    IndexSet boundary(dof.n_dofs(level));
    for (const auto& line : held.get_lines()) boundary.add_index(line.index);
    mg.add_boundary_indices(dof, level, boundary);
  }
}

// The level operators on their MatrixFree data, with diagonals and λ, μ.
void setup_levels(const State<kDim>& m, const DoFHandler<kDim>& dof, const MGConstrainedDoFs& mg,
                  MGLevelObject<LevelOperator>& ops) {
  const unsigned n_levels = dof.get_triangulation().n_global_levels();
  ops.resize(0, n_levels - 1);
  for (unsigned level = 0; level < n_levels; ++level) {
    IndexSet relevant;
    DoFTools::extract_locally_relevant_level_dofs(dof, level, relevant);
    AffineConstraints<double> level_constraints;
    level_constraints.reinit(relevant);
    level_constraints.add_lines(mg.get_boundary_indices(level));
    level_constraints.close();
    typename MatrixFree<kDim, float>::AdditionalData data;
    data.tasks_parallel_scheme = MatrixFree<kDim, float>::AdditionalData::none;
    data.mapping_update_flags = update_gradients | update_JxW_values;
    data.mg_level = level;
    auto mf = std::make_shared<MatrixFree<kDim, float>>();
    mf->reinit(*m.mapping, dof, level_constraints, QGauss<1>(2), data);
    ops[level].initialize(mf, mg, level);
    ops[level].set_material(m);
    ops[level].compute_diagonal();
  }
}

}  // namespace

bool voxel_multigrid_applies(const State<kDim>& m, const DistributedSystem<kDim>& sys) {
  int oblique = 0;
  for (const auto& line : sys.constraints.get_lines()) oblique |= line.entries.empty() ? 0 : 1;
  (void)m;
  return Utilities::MPI::max(oblique, sys.dof.get_communicator()) == 0;
}

TrilinosWrappers::MPI::Vector solve_voxel_multigrid(const State<kDim>& m, const DistributedSystem<kDim>& sys,
                                                    const SolverOptions& opt, MPI_Comm comm,
                                                    SolverStats& stats) {
  Timer timer;
  // The fine operator: the Dirichlet DoFs held at zero (their values are in sys.f already).
  AffineConstraints<double> zero;
  zero.reinit(sys.relevant);
  for (const auto& line : sys.constraints.get_lines()) zero.add_line(line.index);
  zero.close();
  typename MatrixFree<kDim, double>::AdditionalData data;
  data.tasks_parallel_scheme = MatrixFree<kDim, double>::AdditionalData::none;
  data.mapping_update_flags = update_gradients | update_JxW_values;
  auto fine_mf = std::make_shared<MatrixFree<kDim, double>>();
  fine_mf->reinit(*m.mapping, sys.dof, zero, QGauss<1>(2), data);
  ElasticityOperator<double> fine;
  fine.initialize(fine_mf);
  fine.set_material(m);

  MGConstrainedDoFs mg_constrained;
  mg_constrained.initialize(sys.dof);
  add_level_boundary_indices(m, sys.dof, mg_constrained);
  MGLevelObject<LevelOperator> levels;
  setup_levels(m, sys.dof, mg_constrained, levels);
  MGTransferMatrixFree<kDim, float> transfer(mg_constrained);
  transfer.build(sys.dof);

  using Smoother = PreconditionChebyshev<LevelOperator, LevelVector>;
  mg::SmootherRelaxation<Smoother, LevelVector> smoother;
  MGLevelObject<typename Smoother::AdditionalData> smoother_data(0, levels.max_level());
  for (unsigned level = 0; level <= levels.max_level(); ++level) {
    if (level > 0) {
      smoother_data[level].smoothing_range = 15.;
      smoother_data[level].degree = 5;
      smoother_data[level].eig_cg_n_iterations = 10;
    } else {  // the coarse solve: Chebyshev to a 1e-3 reduction
      smoother_data[0].smoothing_range = 1e-3;
      smoother_data[0].degree = numbers::invalid_unsigned_int;
      smoother_data[0].eig_cg_n_iterations = std::min<unsigned>(levels[0].m(), 300);
    }
    smoother_data[level].preconditioner = levels[level].get_matrix_diagonal_inverse();
  }
  smoother.initialize(levels, smoother_data);
  MGCoarseGridApplySmoother<LevelVector> coarse;
  coarse.initialize(smoother);
  mg::Matrix<LevelVector> level_matrix(levels);
  Multigrid<LevelVector> multigrid(level_matrix, coarse, transfer, smoother, smoother);
  PreconditionMG<kDim, LevelVector, MGTransferMatrixFree<kDim, float>> preconditioner(sys.dof, multigrid,
                                                                                      transfer);
  stats.precondition_seconds = timer.wall_time();

  LinearAlgebra::distributed::Vector<double> u, b;
  fine_mf->initialize_dof_vector(u);
  fine_mf->initialize_dof_vector(b);
  for (const auto i : sys.owned) b(i) = sys.f(i);
  zero.set_zero(b);
  solve_cg_to_tolerance(fine, u, b, preconditioner, opt, stats, "CG with matrix-free multigrid");
  TrilinosWrappers::MPI::Vector out(sys.owned, comm);
  for (const auto i : sys.owned) out(i) = u(i);
  out.compress(VectorOperation::insert);
  return out;
}

}  // namespace vim::fem

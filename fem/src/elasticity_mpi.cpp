// The same elasticity problem distributed over MPI ranks (DESIGN.md §4): simplex models on a
// parallel::shared::Triangulation (a copy of the serial triangulation every rank holds, METIS
// partition, cells away from the own part artificial); voxel models on a p4est
// parallel::distributed::Triangulation built from the grid description alone (no serial mesh).
// Each rank assembles its cells into Trilinos matrices and solves with CG + ML AMG fed the
// rigid-body modes. Outputs are gathered so every rank gets the full Solution.
#include "elasticity_impl.hpp"

#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/shared_tria.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_sparsity_pattern.h>
#include <deal.II/lac/trilinos_vector.h>

#include <Epetra_MultiVector.h>
#include <Teuchos_ParameterList.hpp>

#include <dlfcn.h>

#include <cfloat>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace vim::fem {

using namespace dealii;

namespace {
// One thread per rank while a multi-rank solve runs (restored afterwards). OpenBLAS, which Trilinos
// ML calls, keeps nproc − 1 worker threads per process that spin in sched_yield after each BLAS call
// (perf, 1 rank: 12 % of the samples in that thread); with a rank per core they take CPU from the
// other ranks. The same holds for OpenMP (libgomp) teams and deal.II's TBB tasks. The BLAS and OpenMP
// setters are looked up at run time: absent (another BLAS, no OpenMP) means nothing to limit.
class OneThreadPerRank {
 public:
  OneThreadPerRank()
      : blas_get_(reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"))),
        blas_set_(reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))),
        omp_get_(reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "omp_get_max_threads"))),
        omp_set_(reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"))),
        tbb_saved_(MultithreadInfo::n_threads()) {
    if (blas_get_ && blas_set_) blas_saved_ = blas_get_(), blas_set_(1);
    if (omp_get_ && omp_set_) omp_saved_ = omp_get_(), omp_set_(1);
    MultithreadInfo::set_thread_limit(1);
  }
  ~OneThreadPerRank() {
    if (blas_saved_ > 1) blas_set_(blas_saved_);
    if (omp_saved_ > 1) omp_set_(omp_saved_);
    MultithreadInfo::set_thread_limit(tbb_saved_);
  }
  OneThreadPerRank(const OneThreadPerRank&) = delete;
  OneThreadPerRank& operator=(const OneThreadPerRank&) = delete;

 private:
  int (*blas_get_)();
  void (*blas_set_)(int);
  int (*omp_get_)();
  void (*omp_set_)(int);
  unsigned tbb_saved_;
  int blas_saved_ = 0, omp_saved_ = 0;
};
}  // namespace

template <int dim>
Solution<dim> ElasticModel<dim>::solve_distributed(MPI_Comm comm, const SolverOptions& opt) {
  Impl& m = *impl_;
  if (!(opt.tolerance > 0.0) || !std::isfinite(opt.tolerance))
    throw std::invalid_argument("SolverOptions: tolerance must be finite and > 0, got " + std::to_string(opt.tolerance));
  if (opt.max_iterations == 0) throw std::invalid_argument("SolverOptions: max_iterations must be > 0");
  if (!m.supports.empty())
    throw std::invalid_argument("solve_distributed: volume supports (add_volume_support) are not supported; use solve()");
  Timer timer;
  const unsigned n_ranks = Utilities::MPI::n_mpi_processes(comm);
  std::optional<OneThreadPerRank> one_thread;
  if (n_ranks > 1) one_thread.emplace();

  // ---- distributed mesh and DoFs ----
  // Simplex models: parallel::shared::Triangulation (METIS partition, cells away from the own part
  // artificial). deal.II 9.4.1's fullydistributed::Triangulation::create_triangulation sorts the
  // cells with a comparator that binary-searches the coarse-cell map twice per comparison: with
  // every cell a coarse cell (~2M tets for ~1M DoFs) that dominated the set-up (docs/performance.md,
  // issue 5). partition_metis explicitly: partition_auto picks Zoltan's hypergraph partitioner, far
  // slower here.
  // Voxel models: a parallel::distributed::Triangulation (p4est) of a coarse block grid refined
  // globally r times (2^r the largest power of two dividing every axis), so a rank holds the coarse
  // grid plus its own part of the voxel grid and never the whole serial mesh; each cell's modulus is
  // looked up by its centre (material id = voxel index).
  std::unique_ptr<parallel::TriangulationBase<dim>> ptria;
  if (m.voxel) {
    auto t = std::make_unique<parallel::distributed::Triangulation<dim>>(comm);
    unsigned r = 0;
    auto divisible = [&](unsigned k) {
      for (int d = 0; d < dim; ++d)
        if (m.grid_cells[d] % (1L << k) != 0) return false;
      return true;
    };
    while (r < 10 && divisible(r + 1)) ++r;
    std::vector<unsigned> reps(dim);
    for (int d = 0; d < dim; ++d) reps[d] = static_cast<unsigned>(m.grid_cells[d] >> r);
    GridGenerator::subdivided_hyper_rectangle(*t, reps, m.grid_min, m.grid_max);
    t->refine_global(r);
    for (const auto& cell : t->active_cell_iterators())
      if (!cell->is_artificial()) cell->set_material_id(static_cast<types::material_id>(m.voxel_index(cell->center())));
    ptria = std::move(t);
  } else {
    auto t = std::make_unique<parallel::shared::Triangulation<dim>>(
        comm, Triangulation<dim>::none, /*allow_artificial_cells=*/true, parallel::shared::Triangulation<dim>::partition_metis);
    t->copy_triangulation(m.tria);
    ptria = std::move(t);
  }
  DoFHandler<dim> dof(*ptria);
  dof.distribute_dofs(*m.fe);
  const IndexSet owned = dof.locally_owned_dofs();
  IndexSet relevant;
  DoFTools::extract_locally_relevant_dofs(dof, relevant);

  // ---- support points of the relevant DoFs; Dirichlet constraints (first condition wins) ----
  const FiniteElement<dim>& fe = *m.fe;
  const unsigned dpc = fe.n_dofs_per_cell();
  // per relevant DoF (position in `relevant`): support point and component
  std::vector<Point<dim>> rel_point(relevant.n_elements());
  std::vector<unsigned char> rel_comp(relevant.n_elements());
  if (m.degree == 1) {
    // P1/Q1: every DoF sits on a vertex (component c of vertex v is vertex_dof_index(v, c))
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      for (const unsigned v : cell->vertex_indices())
        for (unsigned c = 0; c < unsigned(dim); ++c) {
          const auto k = relevant.index_within_set(cell->vertex_dof_index(v, c));
          rel_point[k] = cell->vertex(v);
          rel_comp[k] = static_cast<unsigned char>(c);
        }
    }
  } else {
    Quadrature<dim> sq(fe.get_unit_support_points());
    FEValues<dim> sv(*m.mapping, fe, sq, update_quadrature_points);
    std::vector<types::global_dof_index> idx(dpc);
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      sv.reinit(cell);
      cell->get_dof_indices(idx);
      for (unsigned i = 0; i < dpc; ++i) {
        const auto k = relevant.index_within_set(idx[i]);
        rel_point[k] = sv.quadrature_point(i);
        rel_comp[k] = static_cast<unsigned char>(fe.system_to_component_index(i).first);
      }
    }
  }
  AffineConstraints<double> constraints(relevant);
  std::unordered_map<types::global_dof_index, int> dof_bc;
  std::vector<std::pair<Point<dim>, Tensor<1, dim>>> constrained_owned;
  {
    // The DoFs at one support point share their owner, so a point counts on one rank.
    std::vector<char> seen(relevant.n_elements(), 0);
    std::vector<types::global_dof_index> idx(dpc);
    std::vector<std::array<types::global_dof_index, dim>> groups;
    const auto hold = [&dof_bc](types::global_dof_index i, int b) { dof_bc[i] = b; };
    for (const auto& cell : dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      cell->get_dof_indices(idx);
      dof_groups<dim>(fe, idx, groups);
      for (const auto& g : groups) {
        const auto k = relevant.index_within_set(g[0]);
        if (seen[k]) continue;
        seen[k] = 1;
        m.constrain_point(rel_point[k], g, constraints, hold, owned.is_element(g[0]) ? &constrained_owned : nullptr);
      }
    }
  }
  constraints.close();
  m.check_rigid_modes_removed(constrained_owned, comm);

  const double setup_seconds = timer.wall_time();

  // ---- assembly ----
  TrilinosWrappers::SparseMatrix K;
  {
    // deal.II's DynamicSparsityPattern + distribute_sparsity_pattern: inserting into the Trilinos
    // (Epetra_FECrsGraph) pattern directly took ~3x the assembly time on the voxel grids.
    DynamicSparsityPattern dsp(relevant);
    DoFTools::make_sparsity_pattern(dof, dsp, constraints, false);
    SparsityTools::distribute_sparsity_pattern(dsp, owned, comm, relevant);
    K.reinit(owned, owned, dsp, comm);
  }  // the pattern is copied into K: free it before the AMG set-up
  TrilinosWrappers::MPI::Vector f(owned, comm);
  auto fv = m.make_fe_values();
  auto ffv = m.make_face_values();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& cell : dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    cell->get_dof_indices(idx);
    constraints.distribute_local_to_global(Ke, Fe, idx, K, f);
  }
  K.compress(VectorOperation::add);
  f.compress(VectorOperation::add);
  const double assemble_seconds = timer.wall_time();

  // ---- CG + AMG with the rigid-body modes ----
  timer.restart();
  Vec<dim> lo = m.vertices[0], hi = m.vertices[0];
  for (const auto& v : m.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  Point<dim> mid;
  for (int d = 0; d < dim; ++d) mid[d] = 0.5 * (lo[d] + hi[d]);
  TrilinosWrappers::PreconditionAMG amg;
  Timer amg_timer;
  amg_setup<dim>(
      K, [&](unsigned i) { return Point<dim>(rel_point[relevant.index_within_set(owned.nth_index_in_set(i))] - mid); },
      [&](unsigned i) { return unsigned(rel_comp[relevant.index_within_set(owned.nth_index_in_set(i))]); }, m.degree,
      m.voxel, amg);
  const double precondition_seconds = amg_timer.wall_time();
  TrilinosWrappers::MPI::Vector u(owned, comm);
  const double fn = f.l2_norm();
  unsigned iterations = 0;
  double residual = 0.0;
  if (fn > 0.0) {
    SolverControl control(opt.max_iterations, opt.tolerance * fn);
    SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
    try {
      cg.solve(K, u, f, amg);
    } catch (const SolverControl::NoConvergence& e) {
      std::ostringstream s;
      s << "solve_distributed: CG+AMG did not converge in " << e.last_step << " iterations (relative residual "
        << e.last_residual / fn << ", tolerance " << opt.tolerance << ")";
      throw std::runtime_error(s.str());
    }
    iterations = control.last_step();
    residual = control.last_value() / fn;
  }
  constraints.distribute(u);
  TrilinosWrappers::MPI::Vector ug(owned, relevant, comm);
  ug = u;
  const double solve_seconds = timer.wall_time();

  // ---- outputs, gathered ----
  Solution<dim> s;
  const std::size_t nv = m.vertices.size(), nc = m.E.size();
  std::vector<double> vert(nv * dim, -DBL_MAX);                     // MAX-reduced: shared vertices agree
  std::vector<double> cellf(nc * (2 * dim * dim + 1), 0.0);         // SUM-reduced: each cell owned once
  std::vector<double> react(m.bcs.size() * dim, 0.0);
  double energy = 0.0;
  Quadrature<dim> cq(std::vector<Point<dim>>{m.unit_centroid});
  FEValues<dim> cv(*m.mapping, fe, cq, update_gradients);
  std::vector<double> ue(dpc);
  Vector<double> uev(dpc), Ku(dpc);
  for (const auto& cell : dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < dpc; ++i) uev[i] = ue[i] = ug[idx[i]];
    if (m.voxel) {
      // vertices: lexicographic grid index from the position (the numbering of m.vertices)
      for (const unsigned v : cell->vertex_indices()) {
        std::size_t gv = 0, stride = 1;
        for (int d = 0; d < dim; ++d) {
          const double h = (m.grid_max[d] - m.grid_min[d]) / m.grid_cells[d];
          const long i = std::lround((cell->vertex(v)[d] - m.grid_min[d]) / h);
          gv += static_cast<std::size_t>(i) * stride;
          stride *= static_cast<std::size_t>(m.grid_cells[d] + 1);
        }
        for (unsigned c = 0; c < unsigned(dim); ++c) vert[gv * dim + c] = ug[cell->vertex_dof_index(v, c)];
      }
    } else {
      // vertices: the shared triangulation is a copy of the serial one, same vertex numbering
      const auto& serial_vertices = m.tria.get_vertices();
      for (const unsigned v : cell->vertex_indices()) {
        const unsigned gv = cell->vertex_index(v);
        if (gv >= serial_vertices.size() || serial_vertices[gv].distance(cell->vertex(v)) > 1e-12 * cell->diameter())
          throw std::logic_error("solve_distributed: vertex numbering differs from the serial mesh");
        for (unsigned c = 0; c < unsigned(dim); ++c) vert[gv * dim + c] = ug[cell->vertex_dof_index(v, c)];
      }
    }
    const unsigned j = cell->material_id();
    Eigen::Matrix<double, dim, dim> eps = m.centroid_strain(cell, cv, ue), sigma;
    double vm = 0;
    m.stress_of(eps, m.E[j], sigma, vm);
    double* out = &cellf[static_cast<std::size_t>(j) * (2 * dim * dim + 1)];
    for (int a = 0; a < dim * dim; ++a) out[a] = eps.data()[a], out[dim * dim + a] = sigma.data()[a];
    out[2 * dim * dim] = vm;
    // energy ½ u_eᵀ K_e u_e and reactions (K_e u_e − F_e) on Dirichlet DoFs, element by element
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    Ke.vmult(Ku, uev);
    energy += 0.5 * (uev * Ku);
    for (unsigned i = 0; i < dpc; ++i) {
      const auto it = dof_bc.find(idx[i]);
      if (it != dof_bc.end()) react[it->second * dim + fe.system_to_component_index(i).first] += Ku[i] - Fe[i];
    }
  }
  Utilities::MPI::max(ArrayView<const double>(vert.data(), vert.size()), comm, ArrayView<double>(vert.data(), vert.size()));
  Utilities::MPI::sum(ArrayView<const double>(cellf.data(), cellf.size()), comm, ArrayView<double>(cellf.data(), cellf.size()));
  Utilities::MPI::sum(ArrayView<const double>(react.data(), react.size()), comm, ArrayView<double>(react.data(), react.size()));
  energy = Utilities::MPI::sum(energy, comm);

  s.vertex_displacement.resize(nv);
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < dim; ++c) s.vertex_displacement[v][c] = vert[v * dim + c] == -DBL_MAX ? 0.0 : vert[v * dim + c];
  s.cell_strain.resize(nc);
  s.cell_stress.resize(nc);
  s.von_mises.resize(nc);
  for (std::size_t j = 0; j < nc; ++j) {
    const double* in = &cellf[j * (2 * dim * dim + 1)];
    for (int a = 0; a < dim * dim; ++a) s.cell_strain[j].data()[a] = in[a], s.cell_stress[j].data()[a] = in[dim * dim + a];
    s.von_mises[j] = in[2 * dim * dim];
  }
  s.dirichlet_reaction.assign(m.bcs.size(), Vec<dim>::Zero());
  for (std::size_t b = 0; b < m.bcs.size(); ++b)
    for (int c = 0; c < dim; ++c) s.dirichlet_reaction[b][c] = react[b * dim + c];
  s.strain_energy = energy;
  s.stats.method = "cg+amg (mpi, " + std::to_string(n_ranks) + " ranks)";
  s.stats.iterations = iterations;
  s.stats.residual = residual;
  s.stats.n_dofs = dof.n_dofs();
  s.stats.assemble_seconds = assemble_seconds;
  s.stats.solve_seconds = solve_seconds;
  s.stats.setup_seconds = setup_seconds;
  s.stats.precondition_seconds = precondition_seconds;
  return s;
}

template Solution<2> ElasticModel<2>::solve_distributed(MPI_Comm, const SolverOptions&);
template Solution<3> ElasticModel<3>::solve_distributed(MPI_Comm, const SolverOptions&);

}  // namespace vim::fem

// The elastic model solved over MPI ranks (docs/architecture.md, fem module): simplex models on a
// parallel::fullydistributed::Triangulation of the rank's part of the mesh (simplex_part.cpp); voxel
// models on a p4est parallel::distributed::Triangulation built from the grid description alone (no
// serial mesh).
// Each rank assembles its cells into Trilinos matrices and solves with CG + ML AMG fed the
// rigid-body modes. Outputs are gathered so every rank gets the full Solution.
// No rank builds the model's serial mesh or DoFs for these solves.
#include <deal.II/base/index_set.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/fully_distributed_tria.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_sparsity_pattern.h>
#include <deal.II/lac/trilinos_vector.h>
#include <dlfcn.h>
#include <p4est_base.h>
#include <sc.h>

#include <algorithm>
#include <cfloat>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <vim/fem/distributed.hpp>

#include "amg.hpp"
#include "distributed_system.hpp"

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

// Simplex models: a parallel::fullydistributed::Triangulation of the rank's cells and their ghosts
// (simplex_part), so the distributed solve keeps only its part of the mesh. Its set-up takes about
// twice the time of a parallel::shared::Triangulation (a copy of the whole serial mesh on every rank)
// on 2 ranks: deal.II 9.4.1's create_triangulation sorts the cells twice with a comparator that
// binary-searches the coarse-cell map, and every tetrahedron is a coarse cell (docs/mpi.md).
// Voxel models: a parallel::distributed::Triangulation (p4est) of a coarse block grid refined
// globally r times (2^r the largest power of two dividing every axis), so a rank holds the coarse
// grid plus its own part of the voxel grid and never the whole serial mesh; each cell's modulus is
// looked up by its centre (material id = voxel index).
// p4est and libsc log every grid operation unless initialised with a log threshold, which deal.II's
// MPI_InitFinalize does; a program that initialises MPI itself (the CLI) does not: silence them once.
void quiet_p4est() {
  static const bool done = [] {
    if (sc_package_id < 0) sc_init(MPI_COMM_WORLD, 0, 0, nullptr, SC_LP_SILENT);
    if (p4est_package_id < 0) p4est_init(nullptr, SC_LP_SILENT);
    return true;
  }();
  (void)done;
}

// Records the cells (material ids) this rank owns in `tria` in m.owned_cells.
template <int dim>
void remember_owned_cells(const State<dim>& m, const parallel::TriangulationBase<dim>& tria, MPI_Comm comm) {
  m.owned_cells.clear();
  for (const auto& cell : tria.active_cell_iterators())
    if (cell->is_locally_owned()) m.owned_cells.push_back(cell->material_id());
  std::sort(m.owned_cells.begin(), m.owned_cells.end());
  m.owned_cells_ranks = Utilities::MPI::n_mpi_processes(comm);
}

// Sets sys.tria (and sys.serial_vertex for simplex models). `multigrid`: the voxel grid keeps its
// level hierarchy on every rank (for the matrix-free multigrid).
template <int dim>
void distributed_triangulation(const State<dim>& m, MPI_Comm comm, bool multigrid,
                               DistributedSystem<dim>& sys) {
  if (!m.voxel) {
    SimplexPart<dim> part = simplex_part<dim>(m.vertices, m.simplices, comm);
    auto t = std::make_unique<parallel::fullydistributed::Triangulation<dim>>(comm);
    t->create_triangulation(part.description);
    sys.serial_vertex = std::move(part.serial_vertex);
    sys.tria = std::move(t);
    return;
  }
  quiet_p4est();
  using Tria = parallel::distributed::Triangulation<dim>;
  auto t = multigrid ? std::make_unique<Tria>(comm, Triangulation<dim>::limit_level_difference_at_vertices,
                                              Tria::construct_multigrid_hierarchy)
                     : std::make_unique<Tria>(comm);
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
    if (!cell->is_artificial())
      cell->set_material_id(static_cast<types::material_id>(m.voxel_index(cell->center())));
  sys.tria = std::move(t);
}

// Support points and components of the relevant DoFs.
template <int dim>
void relevant_support_points(const State<dim>& m, DistributedSystem<dim>& sys) {
  const FiniteElement<dim>& fe = *m.fe;
  sys.rel_point.resize(sys.relevant.n_elements());
  sys.rel_comp.resize(sys.relevant.n_elements());
  if (m.degree == 1) {
    // P1/Q1: every DoF sits on a vertex (component c of vertex v is vertex_dof_index(v, c))
    for (const auto& cell : sys.dof.active_cell_iterators()) {
      if (cell->is_artificial()) continue;
      for (const unsigned v : cell->vertex_indices())
        for (unsigned c = 0; c < unsigned(dim); ++c) {
          const auto k = sys.relevant.index_within_set(cell->vertex_dof_index(v, c));
          sys.rel_point[k] = cell->vertex(v);
          sys.rel_comp[k] = static_cast<unsigned char>(c);
        }
    }
    return;
  }
  Quadrature<dim> sq(fe.get_unit_support_points());
  FEValues<dim> sv(*m.mapping, fe, sq, update_quadrature_points);
  std::vector<types::global_dof_index> idx(fe.n_dofs_per_cell());
  for (const auto& cell : sys.dof.active_cell_iterators()) {
    if (cell->is_artificial()) continue;
    sv.reinit(cell);
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < idx.size(); ++i) {
      const auto k = sys.relevant.index_within_set(idx[i]);
      sys.rel_point[k] = sv.quadrature_point(i);
      sys.rel_comp[k] = static_cast<unsigned char>(fe.system_to_component_index(i).first);
    }
  }
}

// Dirichlet constraints (first condition wins) on the relevant DoFs, then the rigid-mode check over
// all ranks.
template <int dim>
void distributed_constraints(const State<dim>& m, DistributedSystem<dim>& sys, MPI_Comm comm) {
  sys.constraints.reinit(sys.relevant);
  ConstrainedDirections<dim> constrained_owned;
  // The DoFs at one support point share their owner, so a point counts on one rank.
  std::vector<char> seen(sys.relevant.n_elements(), 0);
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  std::vector<std::array<types::global_dof_index, dim>> groups;
  const auto hold = [&sys](types::global_dof_index i, int b) { sys.dof_bc[i] = b; };
  for (const auto& cell : sys.dof.active_cell_iterators()) {
    if (cell->is_artificial()) continue;
    cell->get_dof_indices(idx);
    dof_groups<dim>(*m.fe, idx, groups);
    for (const auto& g : groups) {
      const auto k = sys.relevant.index_within_set(g[0]);
      if (seen[k]) continue;
      seen[k] = 1;
      m.constrain_point(sys.rel_point[k], g, sys.constraints, hold,
                        sys.owned.is_element(g[0]) ? &constrained_owned : nullptr);
    }
  }
  sys.constraints.close();
  check_rigid_modes_removed<dim>(constrained_owned, m.vertices, m.bcs, comm);
}

// K and f, or f alone (the Dirichlet values moved to it through the cell matrices) for a matrix-free solve.
template <int dim>
void assemble_distributed(const State<dim>& m, DistributedSystem<dim>& sys, MPI_Comm comm, bool with_matrix) {
  if (with_matrix) {
    // deal.II's DynamicSparsityPattern + distribute_sparsity_pattern: inserting into the Trilinos
    // (Epetra_FECrsGraph) pattern directly took ~3x the assembly time on the voxel grids.
    DynamicSparsityPattern dsp(sys.relevant);
    DoFTools::make_sparsity_pattern(sys.dof, dsp, sys.constraints, false);
    SparsityTools::distribute_sparsity_pattern(dsp, sys.owned, comm, sys.relevant);
    sys.K.reinit(sys.owned, sys.owned, dsp, comm);
  }  // the pattern is copied into K: free it before the AMG set-up
  sys.f.reinit(sys.owned, comm);
  auto fv = m.make_fe_values();
  auto ffv = m.make_face_values();
  const unsigned dpc = m.fe->n_dofs_per_cell();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& cell : sys.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    cell->get_dof_indices(idx);
    if (with_matrix)
      sys.constraints.distribute_local_to_global(Ke, Fe, idx, sys.K, sys.f);
    else
      sys.constraints.distribute_local_to_global(Fe, idx, sys.f, Ke);
  }
  if (with_matrix) sys.K.compress(VectorOperation::add);
  sys.f.compress(VectorOperation::add);
}

// The AMG preconditioner of the distributed K with the rigid-body modes (rotations about the
// bounding-box centre); returns its set-up time.
template <int dim>
double setup_amg(const State<dim>& m, const DistributedSystem<dim>& sys,
                 TrilinosWrappers::PreconditionAMG& amg) {
  Vec<dim> lo = m.vertices[0], hi = m.vertices[0];
  for (const auto& v : m.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  Point<dim> mid;
  for (int d = 0; d < dim; ++d) mid[d] = 0.5 * (lo[d] + hi[d]);
  const auto local = [&sys](unsigned i) {
    return sys.relevant.index_within_set(sys.owned.nth_index_in_set(i));
  };
  Timer amg_timer;
  amg_setup<dim>(
      sys.K, [&](unsigned i) { return Point<dim>(sys.rel_point[local(i)] - mid); },
      [&](unsigned i) { return unsigned(sys.rel_comp[local(i)]); }, m.degree, m.voxel, amg);
  return amg_timer.wall_time();
}

// u = K⁻¹ b by CG preconditioned with `amg`; fills the iterations and relative residual of `stats`.
template <int dim>
TrilinosWrappers::MPI::Vector solve_cg(const DistributedSystem<dim>& sys,
                                       const TrilinosWrappers::MPI::Vector& b,
                                       const TrilinosWrappers::PreconditionAMG& amg, const SolverOptions& opt,
                                       MPI_Comm comm, SolverStats& stats) {
  TrilinosWrappers::MPI::Vector u(sys.owned, comm);
  solve_cg_to_tolerance(sys.K, u, b, amg, opt, stats, "CG+AMG");
  return u;
}

// The distributed mesh, DoFs, constraints and assembled system of `m` over `comm`; fills the set-up and
// assembly times of `stats`. Returns whether the solve is matrix-free multigrid (3D voxel models
// whose conditions hold DoFs along the axes, when `allow_multigrid`): then K is not assembled.
template <int dim>
bool build_system(const State<dim>& m, DistributedSystem<dim>& sys, MPI_Comm comm, SolverStats& stats,
                  bool allow_multigrid) {
  Timer timer;
  const bool hierarchy = allow_multigrid && m.voxel && dim == 3;
  distributed_triangulation<dim>(m, comm, hierarchy, sys);
  remember_owned_cells<dim>(m, *sys.tria, comm);
  sys.dof.reinit(*sys.tria);
  sys.dof.distribute_dofs(*m.fe);
  if (hierarchy) sys.dof.distribute_mg_dofs();
  sys.owned = sys.dof.locally_owned_dofs();
  DoFTools::extract_locally_relevant_dofs(sys.dof, sys.relevant);
  relevant_support_points<dim>(m, sys);
  distributed_constraints<dim>(m, sys, comm);
  bool multigrid = false;
  if constexpr (dim == 3) multigrid = hierarchy && voxel_multigrid_applies(m, sys);
  stats.setup_seconds = timer.wall_time();
  assemble_distributed<dim>(m, sys, comm, !multigrid);
  stats.assemble_seconds = timer.wall_time();
  return multigrid;
}

// Writes the values of the vertices of `cell` into vert (index: the model's vertex numbering · dim + c).
template <int dim>
void cell_vertex_values(const State<dim>& m, const DistributedSystem<dim>& sys,
                        const typename DoFHandler<dim>::active_cell_iterator& cell,
                        const TrilinosWrappers::MPI::Vector& ug, std::vector<double>& vert) {
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
    return;
  }
  // vertices: the input index of each vertex of the rank's part
  for (const unsigned v : cell->vertex_indices()) {
    const unsigned gv = sys.serial_vertex.at(cell->vertex_index(v));
    if (gv >= m.vertices.size() ||
        (to_vec<dim>(cell->vertex(v)) - m.vertices[gv]).norm() > 1e-12 * cell->diameter())
      throw std::logic_error("solve_distributed: vertex numbering differs from the input mesh");
    for (unsigned c = 0; c < unsigned(dim); ++c) vert[gv * dim + c] = ug[cell->vertex_dof_index(v, c)];
  }
}

// Per-rank shares of the outputs, reduced over the ranks: vertex values (MAX: shared vertices agree),
// per-cell strain, stress and von Mises (SUM: each cell owned once), reactions and energy (SUM).
struct GatheredFields {
  std::vector<double> vert, cellf, react;
  double energy = 0.0;
};

template <int dim>
GatheredFields gather_fields(const State<dim>& m, const DistributedSystem<dim>& sys,
                             const TrilinosWrappers::MPI::Vector& ug, MPI_Comm comm) {
  constexpr int per_cell = 2 * dim * dim + 1;
  GatheredFields g;
  g.vert.assign(m.vertices.size() * dim, -DBL_MAX);
  g.cellf.assign(m.E.size() * per_cell, 0.0);
  g.react.assign(m.bcs.size() * dim, 0.0);
  const unsigned dpc = m.fe->n_dofs_per_cell();
  Quadrature<dim> cq(std::vector<Point<dim>>{m.unit_centroid});
  FEValues<dim> cv(*m.mapping, *m.fe, cq, update_gradients);
  auto fv = m.make_fe_values();
  auto ffv = m.make_face_values();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc), uev(dpc), Ku(dpc);
  std::vector<double> ue(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& cell : sys.dof.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < dpc; ++i) uev[i] = ue[i] = ug[idx[i]];
    cell_vertex_values<dim>(m, sys, cell, ug, g.vert);
    const unsigned j = cell->material_id();
    Eigen::Matrix<double, dim, dim> eps = m.centroid_strain(cell, cv, ue), sigma;
    double vm = 0;
    m.stress_of(eps, m.E[j], sigma, vm);
    double* out = &g.cellf[static_cast<std::size_t>(j) * per_cell];
    for (int a = 0; a < dim * dim; ++a) out[a] = eps.data()[a], out[dim * dim + a] = sigma.data()[a];
    out[2 * dim * dim] = vm;
    // energy ½ u_eᵀ K_e u_e and reactions (K_e u_e − F_e) on Dirichlet DoFs, element by element
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    Ke.vmult(Ku, uev);
    g.energy += 0.5 * (uev * Ku);
    for (unsigned i = 0; i < dpc; ++i) {
      const auto it = sys.dof_bc.find(idx[i]);
      if (it != sys.dof_bc.end())
        g.react[it->second * dim + m.fe->system_to_component_index(i).first] += Ku[i] - Fe[i];
    }
  }
  const auto reduce = [comm](std::vector<double>& v, bool max) {
    if (max)
      Utilities::MPI::max(ArrayView<const double>(v.data(), v.size()), comm,
                          ArrayView<double>(v.data(), v.size()));
    else
      Utilities::MPI::sum(ArrayView<const double>(v.data(), v.size()), comm,
                          ArrayView<double>(v.data(), v.size()));
  };
  reduce(g.vert, true);
  reduce(g.cellf, false);
  reduce(g.react, false);
  g.energy = Utilities::MPI::sum(g.energy, comm);
  return g;
}

template <int dim>
Solution<dim> solution_of(const State<dim>& m, const GatheredFields& g) {
  constexpr int per_cell = 2 * dim * dim + 1;
  Solution<dim> s;
  const std::size_t nv = m.vertices.size(), nc = m.E.size();
  s.vertex_displacement.resize(nv);
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < dim; ++c)
      s.vertex_displacement[v][c] = g.vert[v * dim + c] == -DBL_MAX ? 0.0 : g.vert[v * dim + c];
  s.cell_strain.resize(nc);
  s.cell_stress.resize(nc);
  s.von_mises.resize(nc);
  for (std::size_t j = 0; j < nc; ++j) {
    const double* in = &g.cellf[j * per_cell];
    for (int a = 0; a < dim * dim; ++a)
      s.cell_strain[j].data()[a] = in[a], s.cell_stress[j].data()[a] = in[dim * dim + a];
    s.von_mises[j] = in[2 * dim * dim];
  }
  s.dirichlet_reaction.assign(m.bcs.size(), Vec<dim>::Zero());
  for (std::size_t b = 0; b < m.bcs.size(); ++b)
    for (int c = 0; c < dim; ++c) s.dirichlet_reaction[b][c] = g.react[b * dim + c];
  s.strain_energy = g.energy;
  return s;
}

// Appends a stencil to `out` as numbers: its index i, its number of DoFs, then per DoF: the DoF, its
// component, shape value, condition, whether constrained, inhomogeneity, number of entries and the
// entries (DoF, coefficient). DoF indices are exact as doubles below 2^53.
void pack_stencil(std::size_t i, const PointStencil& st, std::vector<double>& out) {
  out.push_back(static_cast<double>(i));
  out.push_back(static_cast<double>(st.dofs.size()));
  for (const StencilDof& d : st.dofs) {
    out.insert(out.end(),
               {static_cast<double>(d.dof), static_cast<double>(d.comp), d.shape, static_cast<double>(d.bc),
                d.constrained ? 1.0 : 0.0, d.inhomogeneity, static_cast<double>(d.entries.size())});
    for (const auto& [f, a] : d.entries) out.insert(out.end(), {static_cast<double>(f), a});
  }
}

// Reads the stencils packed by pack_stencil into `stencils` (by their index).
void unpack_stencils(const std::vector<double>& in, std::vector<PointStencil>& stencils) {
  std::size_t k = 0;
  const auto next = [&in, &k] { return in.at(k++); };
  while (k < in.size()) {
    PointStencil& st = stencils.at(static_cast<std::size_t>(next()));
    st.inside = true;
    st.dofs.resize(static_cast<std::size_t>(next()));
    for (StencilDof& d : st.dofs) {
      d.dof = static_cast<types::global_dof_index>(next());
      d.comp = static_cast<unsigned>(next());
      d.shape = next();
      d.bc = static_cast<int>(next());
      d.constrained = next() != 0.0;
      d.inhomogeneity = next();
      d.entries.resize(static_cast<std::size_t>(next()));
      for (auto& [f, a] : d.entries) f = static_cast<types::global_dof_index>(next()), a = next();
    }
  }
}

// K⁻¹ over the ranks for the model's solve() (DistributedInverse): the distributed system and its AMG
// kept across calls. Vectors are in the distributed system's DoF numbering, complete on every rank;
// point stencils come from the rank owning the point's cell.
template <int dim>
class DistributedInverseOf : public DistributedInverse<dim> {
 public:
  DistributedInverseOf(const State<dim>& m, MPI_Comm comm, const SolverOptions& opt) : m_(m), comm_(comm) {
    if (!m.supports.empty())
      throw std::invalid_argument(
          "a model with volume supports (add_volume_support) cannot be solved over MPI ranks; run it "
          "serially");
    std::optional<OneThreadPerRank> one_thread;
    if (Utilities::MPI::n_mpi_processes(comm) > 1) one_thread.emplace();
    SolverStats stats;
    build_system<dim>(m, sys_, comm, stats, false);
    choose_solver(opt);
    for (const auto& cell : sys_.dof.active_cell_iterators())
      if (cell->is_locally_owned()) owned_cell_.emplace(cell->material_id(), cell);
  }

  unsigned apply(const Vector<double>* b, Vector<double>& x, const SolverOptions& opt,
                 double* residual) override {
    std::optional<OneThreadPerRank> one_thread;
    if (Utilities::MPI::n_mpi_processes(comm_) > 1) one_thread.emplace();
    x.reinit(sys_.dof.n_dofs());
    SolverStats stats;
    if (mumps_) {  // back-substitution with the kept factor; the owned DoFs are one range
      const auto first = *sys_.owned.begin();
      std::vector<double> rhs(sys_.owned.n_elements());
      for (std::size_t i = 0; i < rhs.size(); ++i) rhs[i] = b ? (*b)[first + i] : sys_.f[first + i];
      mumps_->solve(rhs.data(), x.data() + first);
    } else {
      const TrilinosWrappers::MPI::Vector rhs = b ? owned_part(*b) : sys_.f;
      const TrilinosWrappers::MPI::Vector u = solve_cg<dim>(sys_, rhs, amg_, opt, comm_, stats);
      for (const auto i : sys_.owned) x[i] = u[i];
    }
    sum_over_ranks(x);
    if (residual) *residual = stats.residual;
    return stats.iterations;
  }

  Solution<dim> fields(const Vector<double>& u) override {
    // a copy, not a move: moving the owned vector in would drop the ghost entries of the relevant DoFs
    const TrilinosWrappers::MPI::Vector owned = owned_part(u);
    TrilinosWrappers::MPI::Vector ghosted(sys_.owned, sys_.relevant, comm_);
    ghosted = owned;
    return solution_of<dim>(m_, gather_fields<dim>(m_, sys_, ghosted, comm_));
  }

  std::vector<PointStencil> stencils(const std::vector<std::pair<long, Point<dim>>>& at) override {
    const auto bc_of = [this](types::global_dof_index d) {
      const auto it = sys_.dof_bc.find(d);
      return it == sys_.dof_bc.end() ? -1 : it->second;
    };
    std::vector<double> mine;
    for_each_owned_point(at, [&](std::size_t i, const Cell& cell, const Point<dim>& xi) {
      pack_stencil(i, cell_stencil<dim>(*m_.fe, cell, xi, sys_.constraints, bc_of), mine);
    });
    std::vector<PointStencil> out(at.size());
    for (const std::vector<double>& part : Utilities::MPI::all_gather(comm_, mine))
      unpack_stencils(part, out);
    return out;
  }

  std::vector<std::optional<Vec<dim>>> values(const std::vector<std::pair<long, Point<dim>>>& at,
                                              const Vector<double>& u) override {
    std::vector<double> mine;  // per point found here: its index and value
    for_each_owned_point(at, [&](std::size_t i, const Cell& cell, const Point<dim>& xi) {
      const Vec<dim> v = cell_value<dim>(*m_.fe, cell, xi, u);
      mine.push_back(static_cast<double>(i));
      mine.insert(mine.end(), v.data(), v.data() + dim);
    });
    std::vector<std::optional<Vec<dim>>> out(at.size());
    for (const std::vector<double>& part : Utilities::MPI::all_gather(comm_, mine))
      for (std::size_t k = 0; k < part.size(); k += dim + 1)
        out.at(static_cast<std::size_t>(part[k])) = Vec<dim>(Eigen::Map<const Vec<dim>>(&part[k + 1]));
    return out;
  }

  void distribute_constraints(Vector<double>& u) override {
    Vector<double> w(u.size());
    for (const auto i : sys_.owned) {
      if (!sys_.constraints.is_constrained(i)) {
        w[i] = u[i];
        continue;
      }
      w[i] = sys_.constraints.get_inhomogeneity(i);
      if (const auto* entries = sys_.constraints.get_constraint_entries(i))
        for (const auto& [f, a] : *entries) w[i] += a * u[f];
    }
    sum_over_ranks(w);
    u.swap(w);
  }

  types::global_dof_index n_dofs() const override { return sys_.dof.n_dofs(); }

  std::size_t cells_held() const override {
    std::size_t n = 0;
    for (const auto& cell : sys_.tria->active_cell_iterators()) n += cell->is_artificial() ? 0 : 1;
    return n;
  }

  std::size_t memory_consumption() const override {
    return sys_.tria->memory_consumption() + sys_.dof.memory_consumption() +
           sys_.constraints.memory_consumption() + sys_.K.memory_consumption() + sys_.f.memory_consumption() +
           amg_.memory_consumption() + MemoryConsumption::memory_consumption(sys_.rel_point) +
           MemoryConsumption::memory_consumption(sys_.serial_vertex);  // as serially, without the factor
  }

  const std::string& method() const override { return method_; }
  const std::string& reason() const override { return reason_; }

 private:
  using Cell = typename DoFHandler<dim>::active_cell_iterator;

  // Calls f(i, cell, xi) for each point at[i] whose cell this rank owns and that lies in it (reference
  // point xi), in order.
  template <class F>
  void for_each_owned_point(const std::vector<std::pair<long, Point<dim>>>& at, const F& f) const {
    for (std::size_t i = 0; i < at.size(); ++i) {
      if (at[i].first < 0) continue;
      const auto cell = owned_cell_.find(static_cast<types::material_id>(at[i].first));
      if (cell == owned_cell_.end()) continue;
      if (const auto xi = reference_point<dim>(*m_.mapping, cell->second, at[i].second))
        f(i, cell->second, *xi);
    }
  }

  // The entries of a complete vector at this rank's owned DoFs, as a distributed vector.
  TrilinosWrappers::MPI::Vector owned_part(const Vector<double>& complete) const {
    TrilinosWrappers::MPI::Vector v(sys_.owned, comm_);
    std::vector<types::global_dof_index> idx;
    std::vector<double> values;
    idx.reserve(sys_.owned.n_elements()), values.reserve(sys_.owned.n_elements());
    for (const auto i : sys_.owned) idx.push_back(i), values.push_back(complete[i]);
    v.set(idx, values);
    v.compress(VectorOperation::insert);
    return v;
  }

  // MUMPS's factor of K (kept, its owned rows one range) when `opt` chooses it and it fits, else the AMG.
  void choose_solver(const SolverOptions& opt) {
    const unsigned ranks = Utilities::MPI::n_mpi_processes(comm_);
    const std::string on = " (mpi, " + std::to_string(ranks) + " ranks)";
    using Type = SolverOptions::Type;
    const bool contiguous = Utilities::MPI::min(sys_.owned.is_contiguous() ? 1 : 0, comm_) == 1;
    if (opt.type == Type::direct || (opt.type == Type::automatic && !m_.voxel && contiguous)) {
      if (!contiguous) throw std::logic_error("solve_distributed: the ranks' DoFs are not contiguous ranges");
      mumps_ = factorise_if_fits(mumps_of(sys_.K, sys_.owned, comm_), opt, sys_.dof.n_dofs(), ranks, reason_);
    } else {
      reason_ = opt.type == Type::amg ? "solver.type amg" : "solver.type auto: voxel model, CG + AMG";
    }
    method_ = (mumps_ ? "mumps" : "cg+amg") + on;
    if (mumps_)
      sys_.K.clear();  // the factor replaces it
    else
      setup_amg<dim>(m_, sys_, amg_);
  }

  // Each DoF is owned by one rank and zero on the others: the sum over the ranks is exact.
  void sum_over_ranks(Vector<double>& x) const {
    Utilities::MPI::sum(ArrayView<const double>(x.data(), x.size()), comm_,
                        ArrayView<double>(x.data(), x.size()));
  }

  const State<dim>& m_;
  MPI_Comm comm_;
  DistributedSystem<dim> sys_;
  TrilinosWrappers::PreconditionAMG amg_;
  std::unique_ptr<MumpsFactor> mumps_;
  std::string method_, reason_;
  // the locally owned cells by material id (input cell / voxel index)
  std::unordered_map<types::material_id, Cell> owned_cell_;
};

}  // namespace

template <int dim>
std::unique_ptr<DistributedInverse<dim>> make_distributed_inverse(const State<dim>& model, MPI_Comm comm,
                                                                  const SolverOptions& opt) {
  return std::make_unique<DistributedInverseOf<dim>>(model, comm, opt);
}

template <int dim>
void distribute_solves(ElasticModel<dim>& model, MPI_Comm comm) {
  State<dim>& m = ModelAccess::state(model);
  ensure_mpi_initialized();
  m.invalidate();
  m.solve_comm = comm;
}

template <int dim>
Solution<dim> solve_distributed(ElasticModel<dim>& model, MPI_Comm comm, const SolverOptions& opt) {
  const State<dim>& m = ModelAccess::state(model);
  check_solver_options(opt);
  if (!m.supports.empty())
    throw std::invalid_argument(
        "solve_distributed: volume supports (add_volume_support) are not supported; use solve()");
  const unsigned n_ranks = Utilities::MPI::n_mpi_processes(comm);
  std::optional<OneThreadPerRank> one_thread;
  if (n_ranks > 1) one_thread.emplace();

  DistributedSystem<dim> sys;
  SolverStats stats;
  const bool multigrid = build_system<dim>(m, sys, comm, stats, true);
  Timer timer;
  TrilinosWrappers::MPI::Vector u;
  if constexpr (dim == 3)
    if (multigrid) u = solve_voxel_multigrid(m, sys, opt, comm, stats);
  if (!multigrid) {
    TrilinosWrappers::PreconditionAMG amg;
    stats.precondition_seconds = setup_amg<dim>(m, sys, amg);
    u = solve_cg<dim>(sys, sys.f, amg, opt, comm, stats);
  }
  sys.constraints.distribute(u);
  TrilinosWrappers::MPI::Vector ug(sys.owned, sys.relevant, comm);
  ug = u;
  stats.solve_seconds = timer.wall_time();

  Solution<dim> s = solution_of<dim>(m, gather_fields<dim>(m, sys, ug, comm));
  stats.method = std::string(multigrid ? "cg+matrix-free multigrid" : "cg+amg") + " (mpi, " +
                 std::to_string(n_ranks) + " ranks)";
  stats.n_dofs = sys.dof.n_dofs();
  s.stats = stats;
  return s;
}

template <int dim>
std::vector<std::size_t> owned_cells(const ElasticModel<dim>& model, MPI_Comm comm) {
  const State<dim>& m = ModelAccess::state(model);
  ensure_mpi_initialized();
  const unsigned ranks = Utilities::MPI::n_mpi_processes(comm);
  if (m.owned_cells_ranks == ranks) return m.owned_cells;
  if (m.voxel) {  // the p4est partition: the distributed grid without DoFs
    DistributedSystem<dim> sys;
    distributed_triangulation<dim>(m, comm, false, sys);
    remember_owned_cells<dim>(m, *sys.tria, comm);
    return m.owned_cells;
  }
  const std::vector<unsigned> owner = partition_cells<dim>(m.vertices, m.simplices, ranks);
  const unsigned rank = Utilities::MPI::this_mpi_process(comm);
  m.owned_cells.clear();
  for (std::size_t c = 0; c < owner.size(); ++c)
    if (owner[c] == rank) m.owned_cells.push_back(c);
  m.owned_cells_ranks = ranks;
  return m.owned_cells;
}

template Solution<2> solve_distributed<2>(ElasticModel<2>&, MPI_Comm, const SolverOptions&);
template Solution<3> solve_distributed<3>(ElasticModel<3>&, MPI_Comm, const SolverOptions&);
template void distribute_solves<2>(ElasticModel<2>&, MPI_Comm);
template std::vector<std::size_t> owned_cells<2>(const ElasticModel<2>&, MPI_Comm);
template std::vector<std::size_t> owned_cells<3>(const ElasticModel<3>&, MPI_Comm);
template void distribute_solves<3>(ElasticModel<3>&, MPI_Comm);
template std::unique_ptr<DistributedInverse<2>> make_distributed_inverse<2>(const State<2>&, MPI_Comm,
                                                                            const SolverOptions&);
template std::unique_ptr<DistributedInverse<3>> make_distributed_inverse<3>(const State<3>&, MPI_Comm,
                                                                            const SolverOptions&);

}  // namespace vim::fem

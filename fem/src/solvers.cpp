// Linear solvers of the elastic model (docs/architecture.md, fem module): CHOLMOD's sparse Cholesky and
// CG + ML AMG for K u = f, and the condensed solve with embedded point constraints C u = g (rows =
// shape-function values at the point, or their mean over sample points):
//  * K (Dirichlet eliminated) is factorised ONCE (CHOLMOD) and u0 = K⁻¹f kept; columns K⁻¹cᵀ are
//    cached per row (position, direction, samples), with c·u0 and the products c_a K⁻¹c_bᵀ. Then
//    S = C K⁻¹ Cᵀ + diag(κ) (m×m dense), μ = S⁻¹(C u0 − g), u = u0 − K⁻¹Cᵀ μ. Rows not cached yet are
//    computed in one batch of right-hand sides per solve; precompute() does that for every row a needle
//    can use before it steps, so that its steps do no sparse solve. On the AMG path each column is one
//    CG solve with the same AMG preconditioner.
//  * solve_monolithic() (constraint_rows.cpp) is the UMFPACK saddle-point reference.
//  * set_volume_support_base() changes f alone (the load of a moved foundation base): u0 is solved
//    again with the same factor and the cached rows' c·u0 follow it.
// Both satisfy K u + Cᵀ μ = f; the force of the constraint on the body is −Cᵀμ (point_force = −μ).
#include <deal.II/base/timer.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vim/fem/distributed.hpp>

#include "amg.hpp"
#include "constraint_rows.hpp"
#include "input_checks.hpp"

namespace vim::fem {

using namespace dealii;

// ================================================================================================
// K⁻¹: CHOLMOD or CG + AMG

// Trilinos (the AMG preconditioner and its matrix) needs MPI initialised even on one process. Test
// mains and MPI programs do that through deal.II's MPI_InitFinalize; a serial program such as the
// CLI does not, so the first serial AMG set-up initialises MPI itself and finalises it at exit.
void ensure_mpi_initialized() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) return;
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
    throw std::runtime_error(
        "the AMG solver needs MPI, and MPI_Init_thread failed; use solver type 'direct'");
  std::atexit([] {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  });
}

// CHOLMOD's factor of the symmetric K: its rows (CSR) are its columns (CSC); the upper triangle of
// column i is row i's entries with column index ≤ i, sorted.
std::unique_ptr<CholmodLLT> cholmod_factor(const SparseMatrix<double>& K) {
  const auto n = static_cast<long>(K.m());
  std::vector<long> Ap(static_cast<std::size_t>(n) + 1, 0), Ai;
  std::vector<double> Ax;
  std::vector<std::pair<long, double>> column;
  for (long i = 0; i < n; ++i) {
    column.clear();
    for (auto it = K.begin(i); it != K.end(i); ++it)
      if (static_cast<long>(it->column()) <= i)
        column.emplace_back(static_cast<long>(it->column()), it->value());
    std::sort(column.begin(), column.end());
    for (const auto& [row, v] : column) Ai.push_back(row), Ax.push_back(v);
    Ap[static_cast<std::size_t>(i) + 1] = static_cast<long>(Ai.size());
  }
  return std::make_unique<CholmodLLT>(n, Ap, Ai, Ax);
}

template <int dim>
void ElasticModel<dim>::Impl::prepare_solver(const SolverOptions& opt) {
  check_solver_options(opt);
  const bool over_ranks = solves_over_ranks();
  if (!over_ranks) assemble();
  const bool use_amg = opt.type == SolverOptions::Type::amg || (opt.type == SolverOptions::Type::automatic &&
                                                                dof.n_dofs() > opt.direct_limit_for(dim));
  const std::string wanted =
      over_ranks ? "mpi " + std::to_string(static_cast<int>(opt.type)) + " " + std::to_string(opt.max_memory)
      : use_amg  ? "cg+amg"
                 : "cholmod";
  if (prepared_for == wanted) return;
  direct.reset();
  amg.reset();
  K_trilinos.reset();
  distributed.reset();
  have_u0 = false;
  columns.clear();
  Timer timer;
  if (over_ranks) {
    distributed = make_distributed_inverse<dim>(*this, solve_comm, opt);
  } else if (!use_amg) {
    direct = cholmod_factor(K);
  } else {
    ensure_mpi_initialized();
    K_trilinos = std::make_unique<TrilinosWrappers::SparseMatrix>();
    K_trilinos->reinit(K, 0.0);
    // centre the rotations at the bounding-box centre for conditioning
    Point<dim> lo = support_points[0], hi = lo;
    for (const auto& p : support_points)
      for (int d = 0; d < dim; ++d) lo[d] = std::min(lo[d], p[d]), hi[d] = std::max(hi[d], p[d]);
    const Point<dim> mid = 0.5 * (lo + hi);
    amg = std::make_unique<TrilinosWrappers::PreconditionAMG>();
    amg_setup<dim>(
        *K_trilinos, [&](unsigned i) { return Point<dim>(support_points[i] - mid); },
        [&](unsigned i) { return dof_component[i]; }, degree, voxel, *amg);
  }
  prepare_seconds = timer.wall_time();
  prepared_for = wanted;
  method = distributed ? distributed->method() : wanted;
  method_reason = distributed ? distributed->reason() : std::string();
}

template <int dim>
unsigned ElasticModel<dim>::Impl::apply_inverse(const Vector<double>& b, Vector<double>& x,
                                                const SolverOptions& opt, double* residual) const {
  if (distributed) return distributed->apply(&b, x, opt, residual);
  if (direct) {
    x = b;
    direct->solve(x.data());
    if (residual) *residual = 0.0;
    return 0;
  }
  x.reinit(b.size());
  const double bn = b.l2_norm();
  if (bn == 0.0) return 0;
  SolverControl control(opt.max_iterations, opt.tolerance * bn);
  SolverCG<Vector<double>> cg(control);
  try {
    cg.solve(*K_trilinos, x, b, *amg);
  } catch (const SolverControl::NoConvergence& e) {
    std::ostringstream s;
    s << "CG+AMG did not converge in " << e.last_step << " iterations (relative residual "
      << e.last_residual / bn << ", tolerance " << opt.tolerance << ")";
    throw std::runtime_error(s.str());
  }
  if (residual) *residual = control.last_value() / bn;
  return control.last_step();
}

template <int dim>
void ElasticModel<dim>::Impl::ensure_u0(const SolverOptions& opt, double* residual) {
  if (have_u0) return;
  // distributed: the load as the ranks assemble it (Dirichlet values in, like f)
  u0_iterations =
      distributed ? distributed->apply(nullptr, u0, opt, residual) : apply_inverse(f, u0, opt, residual);
  have_u0 = true;
  // A new load (set_volume_support_base): the cached rows keep their columns, their c·u0 follow u0.
  for (auto& [key, e] : columns.entries) {
    e.cu0 = 0.0;
    if (e.row.active)
      for (std::size_t i = 0; i < e.row.dofs.size(); ++i) e.cu0 += e.row.values[i] * u0[e.row.dofs[i]];
  }
}

// ================================================================================================
// the load of the volume supports' bases: a change of f alone

// f_support = Σ_p k w_p N_i(x_p) b_p,c(i) over the points whose base has moved (Dirichlet DoFs dropped,
// as for f), replacing the previous f_support in f.
template <int dim>
void ElasticModel<dim>::Impl::assemble_support_load() {
  if (f_support.size() == f.size()) f -= f_support;
  f_support.reinit(f.size());
  const unsigned dpc = fe->n_dofs_per_cell();
  std::vector<types::global_dof_index> idx(dpc);
  Vector<double> Fe(dpc);
  for (const auto& sup : supports)
    for (std::size_t p = 0; p < sup.base.size(); ++p) {
      if (sup.weights[p] == 0.0 || sup.base[p].isZero(0.0)) continue;
      const auto found = locate(to_point<dim>(sup.points[p]));
      if (found.first == tria.end()) continue;  // outside the mesh: no spring either
      const Cell cell(&tria, found.first->level(), found.first->index(), &dof);
      for (unsigned i = 0; i < dpc; ++i)
        Fe[i] = sup.stiffness * sup.weights[p] * fe->shape_value(i, found.second) *
                sup.base[p][fe->system_to_component_index(i).first];
      cell->get_dof_indices(idx);
      constraints.distribute_local_to_global(Fe, idx, f_support);
    }
  f += f_support;
}

template <int dim>
void ElasticModel<dim>::set_volume_support_base(std::size_t index, std::vector<Vec<dim>> base) {
  Impl& m = *impl_;
  if (index >= m.supports.size())
    throw std::invalid_argument("set_volume_support_base: no volume support " + std::to_string(index) +
                                " (the model has " + std::to_string(m.supports.size()) + ")");
  check_support_base<dim>(base, m.supports[index].points.size(),
                          "set_volume_support_base: support '" + m.supports[index].name + "'");
  if (m.solve_comm != MPI_COMM_NULL)
    throw std::invalid_argument("set_volume_support_base: volume supports are solved serially only");
  m.supports[index].base = std::move(base);
  if (!m.matrices_assembled) return;  // the first assembly takes it
  m.assemble_support_load();
  m.have_u0 = false;
}

template <int dim>
std::size_t ElasticModel<dim>::volume_support_points_outside() const {
  return impl_->support_outside;
}

// ================================================================================================
// the column cache

ColumnCache::Entry& ColumnCache::add(Key key, ConstraintRow row, Vector<double> col,
                                     const Vector<double>& u0) {
  Entry e;
  e.id = entries.size();
  if (row.active)
    for (std::size_t i = 0; i < row.dofs.size(); ++i) e.cu0 += row.values[i] * u0[row.dofs[i]];
  e.row = std::move(row);
  e.col = std::move(col);
  const auto need = static_cast<Eigen::Index>(e.id + 1);
  if (gram.rows() < need) {
    const Eigen::Index old = gram.rows(), grown = std::max<Eigen::Index>(64, 2 * need);
    gram.conservativeResize(grown, grown);
    gram.rightCols(grown - old).setConstant(std::numeric_limits<double>::quiet_NaN());
    gram.bottomRows(grown - old).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return entries.emplace(std::move(key), std::move(e)).first->second;
}

double ColumnCache::product(const Entry& a, const Entry& b) {
  double& v = gram(static_cast<Eigen::Index>(a.id), static_cast<Eigen::Index>(b.id));
  if (!std::isnan(v)) return v;
  const auto dot = [](const ConstraintRow& r, const Vector<double>& col) {
    double s = 0.0;
    for (std::size_t i = 0; i < r.dofs.size(); ++i) s += r.values[i] * col[r.dofs[i]];
    return s;
  };
  v = 0.5 * (dot(a.row, b.col) + dot(b.row, a.col));
  gram(static_cast<Eigen::Index>(b.id), static_cast<Eigen::Index>(a.id)) = v;
  return v;
}

// ================================================================================================
// solve(): Schur complement of the point constraints over cached columns K⁻¹cᵀ; precompute()

// The cache key of component direction `dir` of point constraint p: position, direction, then the
// sample offsets and weights.
template <int dim>
ColumnCache::Key column_key(const PointConstraint<dim>& p, const Vec<dim>& dir) {
  ColumnCache::Key k(p.position.data(), p.position.data() + dim);
  k.insert(k.end(), dir.data(), dir.data() + dim);
  for (std::size_t q = 0; q < p.offsets.size(); ++q) {
    k.insert(k.end(), p.offsets[q].data(), p.offsets[q].data() + dim);
    k.push_back(q < p.weights.size() ? p.weights[q] : 0.0);
  }
  k.push_back(static_cast<double>(p.offsets.size()));
  return k;
}

// Columns K⁻¹cᵀ of the active rows of `missing` (each given with its key) in blocks of right-hand sides
// (direct: one sweep through the factor per block; AMG: one CG solve per row), added to the cache.
// Returns the CG iterations.
template <int dim>
unsigned add_columns(State<dim>& m, std::vector<std::pair<ColumnCache::Key, ConstraintRow>>& missing,
                     const SolverOptions& opt) {
  constexpr std::size_t block = 32;
  const std::size_t n = m.n_solve_dofs();
  unsigned iterations = 0;
  std::vector<double> B;
  Vector<double> e(n);
  for (std::size_t first = 0; first < missing.size(); first += block) {
    const std::size_t k = std::min(block, missing.size() - first);
    std::vector<Vector<double>> cols(k);
    if (m.direct) {
      B.assign(n * k, 0.0);
      for (std::size_t j = 0; j < k; ++j) {
        const ConstraintRow& row = missing[first + j].second;
        if (row.active)
          for (std::size_t i = 0; i < row.dofs.size(); ++i) B[j * n + row.dofs[i]] += row.values[i];
      }
      m.direct->solve(B.data(), k);
    }
    for (std::size_t j = 0; j < k; ++j) {
      const ConstraintRow& row = missing[first + j].second;
      if (!row.active) continue;
      if (m.direct) {
        cols[j].reinit(n, true);
        std::copy(B.begin() + static_cast<std::ptrdiff_t>(j * n),
                  B.begin() + static_cast<std::ptrdiff_t>((j + 1) * n), cols[j].begin());
      } else {
        e = 0.0;
        for (std::size_t i = 0; i < row.dofs.size(); ++i) e[row.dofs[i]] += row.values[i];
        iterations += m.apply_inverse(e, cols[j], opt);
      }
    }
    for (std::size_t j = 0; j < k; ++j)
      m.columns.add(std::move(missing[first + j].first), std::move(missing[first + j].second),
                    std::move(cols[j]), m.u0);
  }
  missing.clear();
  return iterations;
}

// The cache entries of the rows of `points` (one per selected component, point-major; each key built
// once), the rows not cached yet computed first in one batch. Adds their CG iterations to
// `iterations` and their number to `computed`.
template <int dim>
std::vector<ColumnCache::Entry*> cached_rows(State<dim>& m, const std::vector<PointConstraint<dim>>& points,
                                             const SolverOptions& opt, unsigned* iterations,
                                             unsigned* computed) {
  std::vector<ColumnCache::Key> keys;
  std::vector<std::pair<ColumnCache::Key, ConstraintRow>> missing;
  std::set<ColumnCache::Key> seen;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c) {
      if (!points[k].components[c]) continue;
      keys.push_back(column_key<dim>(points[k], points[k].axes.col(c)));
      if (m.columns.entries.count(keys.back()) || !seen.insert(keys.back()).second) continue;
      missing.emplace_back(keys.back(), constraint_row<dim>(m, points[k], c, 0.0, k));
    }
  if (computed) *computed += static_cast<unsigned>(missing.size());
  const unsigned it = add_columns<dim>(m, missing, opt);
  if (iterations) *iterations += it;
  std::vector<ColumnCache::Entry*> entries;
  entries.reserve(keys.size());
  for (const auto& key : keys) entries.push_back(&m.columns.entries.at(key));
  return entries;
}

namespace {

// A row of solve() with its cached column K⁻¹cᵀ.
struct SchurRow {
  ColumnCache::Entry* entry;  // the row and its column
  double g;
  double compliance;  // added to the row's diagonal of the Schur complement
  std::size_t point;
  unsigned comp;
};

// The rows of `points` (one per selected component) from the cache, the missing ones computed first
// in one batch (their CG iterations are added to `iterations`).
template <int dim>
std::vector<SchurRow> schur_rows(State<dim>& m, const std::vector<PointConstraint<dim>>& points,
                                 const SolverOptions& opt, unsigned& iterations) {
  const std::vector<ColumnCache::Entry*> entries = cached_rows<dim>(m, points, opt, &iterations, nullptr);
  std::vector<SchurRow> rows;
  std::size_t e = 0;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c) {
      if (!points[k].components[c]) continue;
      ColumnCache::Entry& entry = *entries[e++];
      // g of the cached row holds −c_D·u_D only; add the requested displacement now.
      const double g = points[k].displacement[c] + entry.row.g;
      if (!entry.row.active) {
        check_void_row(g, points[k].displacement[c], k, c);
        continue;
      }
      rows.push_back({&entry, g, points[k].compliance[c], k, c});
    }
  return rows;
}

// S = C K⁻¹ Cᵀ + diag(κ) (symmetrised; products from the cache) and r = C u0 − g over all rows.
void schur_complement(ColumnCache& cache, const std::vector<SchurRow>& rows, Eigen::MatrixXd& S,
                      Eigen::VectorXd& r) {
  const std::size_t n = rows.size();
  S.resize(n, n);
  r.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    r[a] = rows[a].entry->cu0 - rows[a].g;
    for (std::size_t b = 0; b <= a; ++b) S(a, b) = S(b, a) = cache.product(*rows[a].entry, *rows[b].entry);
    S(a, a) += rows[a].compliance;
  }
}

// A row is dropped (in order) when its pivot in an ordered Cholesky of S vanishes: it is then a
// combination of the earlier kept rows (sin² of the angle < 1e-10 in the K⁻¹ metric). Returns the
// kept rows' indices; keep[a] tells whether row a is kept.
std::vector<Eigen::Index> ordered_cholesky_keep(const Eigen::MatrixXd& S, std::vector<bool>& keep) {
  const Eigen::Index n = S.rows();
  keep.assign(static_cast<std::size_t>(n), false);
  std::vector<Eigen::Index> kept;
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);  // Cholesky rows of the kept set
  for (Eigen::Index a = 0; a < n; ++a) {
    const Eigen::Index k = static_cast<Eigen::Index>(kept.size());
    Eigen::VectorXd l(k);
    for (Eigen::Index i = 0; i < k; ++i) {
      double v = S(kept[i], a);
      for (Eigen::Index j = 0; j < i; ++j) v -= L(i, j) * l[j];
      l[i] = v / L(i, i);
    }
    const double d = S(a, a) - l.squaredNorm();
    if (!(S(a, a) > 0.0) || !(d > 1e-10 * S(a, a))) continue;
    keep[static_cast<std::size_t>(a)] = true;
    for (Eigen::Index j = 0; j < k; ++j) L(k, j) = l[j];
    L(k, k) = std::sqrt(d);
    kept.push_back(a);
  }
  return kept;
}

// x = S⁻¹ r for the kept rows' S (SPD for independent rows), or DependentPointConstraints.
// Conditioning of S scaled to a unit diagonal: a chain of shaft points along element edges makes
// it fall geometrically with the chain's length (1e-4 at 8 rows, 1e-18 at 60 along a 2D grid line),
// while the ordered pivots need not vanish (cancellation, depending on the processor's rounding).
// Below 1e-14 the solve's error bound n·ε/rcond exceeds 10% for a few dozen rows: the multipliers
// (the point forces) and the displacements between the points have no reliable digit in the weakest
// direction, so the rows are reported as dependent. (Paths along element edges of a 2D grid whose
// worst step stays at 2e-13 to 8e-13 keep their sampling; the chains that made noise reached 1e-16
// to 1e-18.)
Eigen::VectorXd solve_schur(const Eigen::MatrixXd& S, const Eigen::VectorXd& r) {
  const Eigen::Index nr = S.rows();
  Eigen::LLT<Eigen::MatrixXd> llt(S);
  const Eigen::VectorXd dinv = S.diagonal().cwiseSqrt().cwiseInverse();
  check_scaled_schur(Eigen::LLT<Eigen::MatrixXd>(dinv.asDiagonal() * S * dinv.asDiagonal()), nr);
  if (llt.info() != Eigen::Success) {
    std::ostringstream s;
    s << "the Schur complement of the " << nr
      << " point-constraint rows is not positive definite (nearly dependent rows)";
    throw DependentPointConstraints(s.str());
  }
  return llt.solve(r);
}

}  // namespace

template <int dim>
Solution<dim> ElasticModel<dim>::solve(const std::vector<PointConstraint<dim>>& points,
                                       const SolverOptions& opt) {
  Impl& m = *impl_;
  check_points(points);
  // Without point constraints a distributed voxel model takes solve_distributed as it is: its p4est
  // grid never builds the serial mesh (sample() interpolates the gathered vertex values).
  if (points.empty() && m.voxel && m.solve_comm != MPI_COMM_NULL) {
    Solution<dim> s = solve_distributed(*this, m.solve_comm, opt);
    m.have_solution = false;
    m.grid_vertex_u = s.vertex_displacement;
    return s;
  }
  m.grid_vertex_u.clear();
  if (!m.solves_over_ranks()) m.ensure_mesh();
  m.prepare_solver(opt);
  Timer timer;
  unsigned iterations = 0;
  double residual = 0.0;
  m.ensure_u0(opt, &residual);
  iterations += m.u0_iterations;
  std::vector<SchurRow> rows = schur_rows<dim>(m, points, opt, iterations);
  RowSet all;
  for (const auto& r : rows) all.add(&r.entry->row, r.g, r.point, r.comp);
  Eigen::MatrixXd S_all;
  Eigen::VectorXd r_all;
  schur_complement(m.columns, rows, S_all, r_all);
  std::vector<bool> keep;
  const std::vector<Eigen::Index> kept = ordered_cholesky_keep(S_all, keep);
  const std::size_t n_all = rows.size();
  std::vector<SchurRow> used;
  for (std::size_t a = 0; a < n_all; ++a)
    if (keep[a]) used.push_back(rows[a]);
  rows.swap(used);
  const std::size_t nr = rows.size();
  m.u = m.u0;
  std::vector<double> mu(nr, 0.0);
  if (nr > 0) {
    Eigen::MatrixXd S(nr, nr);
    Eigen::VectorXd r(nr);
    for (std::size_t a = 0; a < nr; ++a) {
      r[a] = r_all[kept[a]];
      for (std::size_t b = 0; b < nr; ++b) S(a, b) = S_all(kept[a], kept[b]);
    }
    const Eigen::VectorXd x = solve_schur(S, r);
    for (std::size_t a = 0; a < nr; ++a) {
      mu[a] = x[a];
      m.u.add(-x[a], rows[a].entry->col);
    }
  }
  double solve_seconds = 0.0;
  Solution<dim> s = finish_constrained_solve<dim>(m, all, keep, points.size(), timer, &solve_seconds);
  for (std::size_t a = 0; a < nr; ++a) {
    s.point_force[rows[a].point] -= mu[a] * points[rows[a].point].axes.col(rows[a].comp);
    add_constraint_reactions<dim>(rows[a].entry->row, mu[a], s);
  }
  s.stats.method = m.method;
  s.stats.reason = m.method_reason;
  s.stats.constraint_rows = static_cast<unsigned>(nr);
  s.stats.dependent_rows_dropped = static_cast<unsigned>(n_all - nr);
  s.stats.iterations = iterations;
  s.stats.residual = residual;
  s.stats.solve_seconds = solve_seconds + m.prepare_seconds;
  s.stats.precondition_seconds = m.prepare_seconds;
  m.prepare_seconds = 0.0;  // count factorisation / AMG setup once
  return s;
}

template <int dim>
unsigned ElasticModel<dim>::precompute(const std::vector<PointConstraint<dim>>& points,
                                       const SolverOptions& opt) {
  Impl& m = *impl_;
  check_points(points);
  if (!m.solves_over_ranks()) m.ensure_mesh();
  m.prepare_solver(opt);
  m.ensure_u0(opt);
  unsigned n = 0;
  const std::vector<ColumnCache::Entry*> entries = cached_rows<dim>(m, points, opt, nullptr, &n);
  std::vector<ColumnCache::Entry*> active;
  for (ColumnCache::Entry* e : entries)
    if (e->row.active) active.push_back(e);
  for (std::size_t a = 0; a < active.size(); ++a)
    for (std::size_t b = 0; b <= a; ++b) m.columns.product(*active[a], *active[b]);
  return n;
}

#define VIM_FEM_SOLVERS(dim)                                                                       \
  template void ElasticModel<dim>::Impl::prepare_solver(const SolverOptions&);                     \
  template unsigned ElasticModel<dim>::Impl::apply_inverse(const Vector<double>&, Vector<double>&, \
                                                           const SolverOptions&, double*) const;   \
  template void ElasticModel<dim>::Impl::ensure_u0(const SolverOptions&, double*);                 \
  template void ElasticModel<dim>::Impl::assemble_support_load();                                  \
  template void ElasticModel<dim>::set_volume_support_base(std::size_t, std::vector<Vec<dim>>);    \
  template std::size_t ElasticModel<dim>::volume_support_points_outside() const;                   \
  template Solution<dim> ElasticModel<dim>::solve(const std::vector<PointConstraint<dim>>&,        \
                                                  const SolverOptions&);                           \
  template unsigned ElasticModel<dim>::precompute(const std::vector<PointConstraint<dim>>&,        \
                                                  const SolverOptions&);                           \
  template ColumnCache::Key column_key<dim>(const PointConstraint<dim>&, const Vec<dim>&);         \
  template std::vector<ColumnCache::Entry*> cached_rows<dim>(                                      \
      State<dim>&, const std::vector<PointConstraint<dim>>&, const SolverOptions&, unsigned*, unsigned*);
VIM_FEM_SOLVERS(2)
VIM_FEM_SOLVERS(3)

}  // namespace vim::fem

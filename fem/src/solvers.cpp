// Linear solvers of the elastic model (docs/architecture.md, fem module): UMFPACK LU and CG + ML AMG for
// K u = f, and the two solves with embedded point constraints C u = g (rows = shape-function values at
// the point):
//  * solve(): K (Dirichlet eliminated) is factorised ONCE (UMFPACK) and u0 = K⁻¹f kept; columns
//    K⁻¹cᵀ are cached per (position, component). Then S = C K⁻¹ Cᵀ (m×m dense),
//    μ = S⁻¹(C u0 − g), u = u0 − K⁻¹Cᵀ μ: a new constraint costs one back-substitution.
//    On the AMG path each column is one CG solve with the same AMG preconditioner.
//  * solve_monolithic(): the saddle-point system [K Cᵀ; C 0] assembled sparse and solved by UMFPACK.
// Both satisfy K u + Cᵀ μ = f; the force of the constraint on the body is −Cᵀμ (point_force = −μ).
#include <deal.II/base/quadrature.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparse_direct.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "amg.hpp"
#include "model_state.hpp"

namespace vim::fem {

using namespace dealii;

template <int dim>
using State = ModelAccess::State<dim>;

// ================================================================================================
// UMFPACK

UmfpackLU::UmfpackLU(const SparseMatrix<double>& K) {
  const auto n = static_cast<SuiteSparse_long>(K.m());
  // K is symmetric, so its rows (CSR) are its columns (CSC); UMFPACK wants sorted indices.
  Ap.assign(n + 1, 0);
  for (SuiteSparse_long i = 0; i < n; ++i)
    Ap[i + 1] = Ap[i] + static_cast<SuiteSparse_long>(K.get_row_length(i));
  Ai.resize(Ap[n]);
  Ax.resize(Ap[n]);
  std::vector<std::pair<SuiteSparse_long, double>> row;
  for (SuiteSparse_long i = 0; i < n; ++i) {
    row.clear();
    for (auto it = K.begin(i); it != K.end(i); ++it)
      row.emplace_back(static_cast<SuiteSparse_long>(it->column()), it->value());
    std::sort(row.begin(), row.end());
    for (std::size_t k = 0; k < row.size(); ++k) Ai[Ap[i] + k] = row[k].first, Ax[Ap[i] + k] = row[k].second;
  }
  umfpack_dl_defaults(control);
  control[UMFPACK_STRATEGY] = UMFPACK_STRATEGY_SYMMETRIC;
  control[UMFPACK_IRSTEP] = 0;
  double info[UMFPACK_INFO];
  int status = umfpack_dl_symbolic(n, n, Ap.data(), Ai.data(), Ax.data(), &symbolic, control, info);
  if (status == UMFPACK_OK)
    status = umfpack_dl_numeric(Ap.data(), Ai.data(), Ax.data(), symbolic, &numeric, control, info);
  if (status != UMFPACK_OK) {
    if (symbolic) umfpack_dl_free_symbolic(&symbolic);
    if (numeric) umfpack_dl_free_numeric(&numeric);
    throw std::runtime_error("UMFPACK factorisation of the stiffness matrix failed (status " +
                             std::to_string(status) +
                             (status == UMFPACK_WARNING_singular_matrix ? ": singular matrix)" : ")"));
  }
  Wi.resize(n);
  W.resize(n);
  b.resize(n);
}

UmfpackLU::~UmfpackLU() {
  if (symbolic) umfpack_dl_free_symbolic(&symbolic);
  if (numeric) umfpack_dl_free_numeric(&numeric);
}

void UmfpackLU::solve(Vector<double>& x) const {
  std::copy(x.begin(), x.end(), b.begin());
  double info[UMFPACK_INFO];
  const int status = umfpack_dl_wsolve(UMFPACK_A, Ap.data(), Ai.data(), Ax.data(), x.data(), b.data(),
                                       numeric, control, info, Wi.data(), W.data());
  if (status != UMFPACK_OK)
    throw std::runtime_error("UMFPACK solve failed (status " + std::to_string(status) + ")");
}

// ================================================================================================
// K⁻¹: UMFPACK or CG + AMG

namespace {

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

}  // namespace

template <int dim>
void ElasticModel<dim>::Impl::prepare_solver(const SolverOptions& opt) {
  check_solver_options(opt);
  assemble();
  const bool use_amg = opt.type == SolverOptions::Type::amg || (opt.type == SolverOptions::Type::automatic &&
                                                                dof.n_dofs() > opt.direct_limit_for(dim));
  const std::string wanted = use_amg ? "cg+amg" : "umfpack";
  if (method == wanted) return;
  direct.reset();
  amg.reset();
  K_trilinos.reset();
  have_u0 = false;
  columns.clear();
  Timer timer;
  if (!use_amg) {
    direct = std::make_unique<UmfpackLU>(K);
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
  method = wanted;
}

template <int dim>
unsigned ElasticModel<dim>::Impl::apply_inverse(const Vector<double>& b, Vector<double>& x,
                                                const SolverOptions& opt, double* residual) const {
  if (direct) {
    x = b;
    direct->solve(x);
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

// ================================================================================================
// point-constraint rows

namespace {

// Adds v to the entry of `dof` in row, or appends it.
void add_to_row(ConstraintRow& row, types::global_dof_index dof, double v) {
  auto at = std::find(row.dofs.begin(), row.dofs.end(), dof);
  if (at == row.dofs.end()) {
    row.dofs.push_back(dof);
    row.values.push_back(v);
  } else {
    row.values[static_cast<std::size_t>(at - row.dofs.begin())] += v;
  }
}

// The sample points of a constraint and their weights summing to 1: the point itself, or its
// averaging samples (PointConstraint::offsets).
template <int dim>
std::vector<std::pair<Vec<dim>, double>> constraint_samples(const PointConstraint<dim>& p,
                                                            std::size_t which) {
  if (p.offsets.empty()) return {{p.position, 1.0}};
  double sum = 0.0;
  for (double w : p.weights) sum += w;
  if (p.weights.size() != p.offsets.size() || !(sum > 0.0) || !std::isfinite(sum))
    throw std::invalid_argument(
        "point constraint " + std::to_string(which) +
        ": an averaged constraint needs one weight ≥ 0 per offset, with a positive sum");
  std::vector<std::pair<Vec<dim>, double>> samples;
  for (std::size_t q = 0; q < p.offsets.size(); ++q) {
    if (!(p.weights[q] >= 0.0) || !p.offsets[q].allFinite())
      throw std::invalid_argument("point constraint " + std::to_string(which) +
                                  ": averaging samples need finite offsets and weights ≥ 0");
    if (p.weights[q] > 0.0) samples.emplace_back(p.position + p.offsets[q], p.weights[q] / sum);
  }
  return samples;
}

// Adds w·a·N(x) (the shape-function values of the cell containing x, along a) to `row`, Dirichlet DoFs
// moved to the right-hand side. Returns false when x lies outside the mesh.
template <int dim>
bool add_sample_to_row(const State<dim>& m, const Vec<dim>& x, const Vec<dim>& a, double w,
                       ConstraintRow& row, double& scale) {
  const auto found = m.locate(to_point<dim>(x));
  if (found.first == m.tria.end()) return false;
  const typename DoFHandler<dim>::active_cell_iterator cell(&m.tria, found.first->level(),
                                                            found.first->index(), &m.dof);
  Quadrature<dim> q(std::vector<Point<dim>>{found.second});
  FEValues<dim> fv(*m.mapping, *m.fe, q, update_values);
  fv.reinit(cell);
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  cell->get_dof_indices(idx);
  for (unsigned i = 0; i < idx.size(); ++i) {
    const double v = w * a[m.fe->system_to_component_index(i).first] * fv.shape_value(i, 0);
    scale = std::max(scale, std::abs(v));
    if (v == 0.0) continue;
    if (m.dof_bc[idx[i]] >= 0) {  // for the reactions: the row's own coefficients on held DoFs
      row.dirichlet_dofs.push_back(idx[i]);
      row.dirichlet_values.push_back(v);
    }
    if (const auto* entries = m.constraints.get_constraint_entries(idx[i])) {
      // u_i = h + Σ a_f u_f (a support along other axes): h moves to g, v·a_f onto the free DoFs f.
      row.g -= v * m.constraints.get_inhomogeneity(idx[i]);
      for (const auto& [f, af] : *entries) add_to_row(row, f, v * af);
    } else {
      add_to_row(row, idx[i], v);
    }
  }
  return true;
}

// Row of C for direction a (a unit vector; e_c for component c = axes.col(c)) of point constraint p:
// a·N at the point, or the weighted mean of a·N over its samples (those inside the mesh, renormalised),
// Dirichlet DoFs moved to the right-hand side. `c` only names the component in messages.
template <int dim>
ConstraintRow constraint_row(const State<dim>& m, const PointConstraint<dim>& p, unsigned c, double g,
                             std::size_t which) {
  const Vec<dim> a = p.axes.col(c);
  auto samples = constraint_samples(p, which);
  double inside = 0.0;
  std::vector<bool> in(samples.size());
  for (std::size_t q = 0; q < samples.size(); ++q)
    if ((in[q] = m.locate(to_point<dim>(samples[q].first)).first != m.tria.end()))
      inside += samples[q].second;
  if (!(inside > 0.0)) {
    std::ostringstream s;
    s << "point constraint " << which << " at " << fmt_point(p.position.data(), dim)
      << (p.offsets.empty() ? " lies outside the mesh" : ": all its averaging samples lie outside the mesh");
    throw std::invalid_argument(s.str());
  }
  ConstraintRow row;
  row.g = g;
  row.compliance = p.compliance[c];
  double scale = 0.0;
  for (std::size_t q = 0; q < samples.size(); ++q)
    if (in[q]) add_sample_to_row<dim>(m, samples[q].first, a, samples[q].second / inside, row, scale);
  double free_scale = 0.0;
  for (double v : row.values) free_scale = std::max(free_scale, std::abs(v));
  if (!(free_scale > 1e-12 * scale)) {
    if (std::abs(row.g) > 1e-12 * (1.0 + std::abs(g))) {
      std::ostringstream s;
      s << "point constraint " << which << " at " << fmt_point(p.position.data(), dim) << " (component " << c
        << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
      throw std::invalid_argument(s.str());
    }
    row.active = false;
  }
  return row;
}

// Greedy, in the given order: a row numerically in the span of earlier kept rows is not kept.
std::vector<bool> independent_rows(const std::vector<const ConstraintRow*>& rows) {
  std::unordered_map<types::global_dof_index, int> col;
  for (const auto* r : rows)
    for (auto d : r->dofs) col.emplace(d, static_cast<int>(col.size()));
  std::vector<Eigen::VectorXd> basis;
  std::vector<bool> keep(rows.size(), false);
  for (std::size_t a = 0; a < rows.size(); ++a) {
    if (rows[a]->compliance > 0.0) {  // [C −κ] rows are independent whatever C
      keep[a] = true;
      continue;
    }
    Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(col.size()));
    for (std::size_t i = 0; i < rows[a]->dofs.size(); ++i) v[col[rows[a]->dofs[i]]] += rows[a]->values[i];
    const double n0 = v.norm();
    for (int pass = 0; pass < 2; ++pass)
      for (const auto& b : basis) v -= b.dot(v) * b;
    if (v.norm() > 1e-9 * n0) {
      keep[a] = true;
      basis.push_back(v / v.norm());
    }
  }
  return keep;
}

// The rows of one constrained solve, in order, with the right-hand sides g and (point, component) of each.
struct RowSet {
  std::vector<const ConstraintRow*> rows;
  std::vector<double> g;
  std::vector<std::pair<std::size_t, unsigned>> which;
  void add(const ConstraintRow* row, double gi, std::size_t point, unsigned comp) {
    rows.push_back(row);
    g.push_back(gi);
    which.emplace_back(point, comp);
  }
};

// Dropped (dependent) rows must hold for the solution anyway; otherwise they conflict.
void check_dropped_rows(const RowSet& set, const std::vector<bool>& keep, const Vector<double>& u) {
  double scale = u.linfty_norm();
  for (double v : set.g) scale = std::max(scale, std::abs(v));
  for (std::size_t a = 0; a < set.rows.size(); ++a) {
    if (keep[a]) continue;
    const ConstraintRow& row = *set.rows[a];
    double cu = 0.0;
    for (std::size_t i = 0; i < row.dofs.size(); ++i) cu += row.values[i] * u[row.dofs[i]];
    if (std::abs(cu - set.g[a]) > 1e-8 * scale) {
      std::ostringstream s;
      s << "point constraint " << set.which[a].first << " (component " << set.which[a].second
        << ") conflicts with earlier point constraints: it is a linear combination of them (e.g. a third "
           "point "
           "on a line inside one P1 element, or a repeated point) but asks for a different displacement "
           "(misfit "
        << cu - set.g[a] << ")";
      throw DependentPointConstraints(s.str());
    }
  }
}

template <int dim>
void check_points(const std::vector<PointConstraint<dim>>& points) {
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!points[k].position.allFinite() || !points[k].displacement.allFinite())
      throw std::invalid_argument("point constraint " + std::to_string(k) +
                                  " has a non-finite position or displacement");
    if (!(points[k].compliance.minCoeff() >= 0.0) || !points[k].compliance.allFinite())
      throw std::invalid_argument("point constraint " + std::to_string(k) +
                                  " has a compliance that is negative or not finite");
    if (!is_orthonormal<dim>(points[k].axes))
      throw std::invalid_argument(
          "point constraint " + std::to_string(k) +
          " has axes that are not orthonormal (its columns must be unit, mutually orthogonal directions)");
  }
}

// The full system reads K u = f + r − Cᵀμ on every DoF (r: support reactions), so on Dirichlet
// DoFs r = K u − f + C_Dᵀ μ: add the constraint rows' Dirichlet parts to the reactions.
template <int dim>
void add_constraint_reactions(const State<dim>& m, const ConstraintRow& row, double mu, Solution<dim>& s) {
  for (std::size_t i = 0; i < row.dirichlet_dofs.size(); ++i) {
    const auto d = row.dirichlet_dofs[i];
    const int b = m.dof_bc[d];
    if (b >= 0) s.dirichlet_reaction[b][m.dof_component[d]] += mu * row.dirichlet_values[i];
  }
}

// After a constrained solve of m.u (free DoFs): checks the dropped rows, distributes the Dirichlet
// values and post-processes; the point forces are left zero for the caller to fill in.
template <int dim>
Solution<dim> finish_constrained_solve(State<dim>& m, const RowSet& set, const std::vector<bool>& keep,
                                       std::size_t n_points, const Timer& timer, double* solve_seconds) {
  check_dropped_rows(set, keep, m.u);
  m.constraints.distribute(m.u);
  m.have_solution = true;
  *solve_seconds = timer.wall_time();
  Solution<dim> s = m.postprocess();
  s.point_force.assign(n_points, Vec<dim>::Zero());
  return s;
}

}  // namespace

// ================================================================================================
// solve(): Schur complement of the point constraints over cached columns K⁻¹cᵀ

namespace {

// A row of solve() with its cached column K⁻¹cᵀ.
struct SchurRow {
  const ConstraintRow* row;
  const Vector<double>* col;
  double g;
  double compliance;  // added to the row's diagonal of the Schur complement
  std::size_t point;
  unsigned comp;
};

// The rows of `points` (one per selected component), each from the cache or computed with its column
// (one K⁻¹ application, whose CG iterations are added to `iterations`).
template <int dim>
std::vector<SchurRow> schur_rows(State<dim>& m, const std::vector<PointConstraint<dim>>& points,
                                 const SolverOptions& opt, unsigned& iterations) {
  const auto key_of = [](const PointConstraint<dim>& p, const Vec<dim>& dir) {
    std::vector<double> k(p.position.data(), p.position.data() + dim);
    k.insert(k.end(), dir.data(), dir.data() + dim);
    for (std::size_t q = 0; q < p.offsets.size(); ++q) {
      k.insert(k.end(), p.offsets[q].data(), p.offsets[q].data() + dim);
      k.push_back(q < p.weights.size() ? p.weights[q] : 0.0);
    }
    k.push_back(static_cast<double>(p.offsets.size()));
    return k;
  };
  std::vector<SchurRow> rows;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c) {
      if (!points[k].components[c]) continue;
      const Vec<dim> dir = points[k].axes.col(c);
      const typename State<dim>::Key key = key_of(points[k], dir);
      auto it = m.columns.find(key);
      if (it == m.columns.end()) {
        ConstraintRow row = constraint_row<dim>(m, points[k], c, 0.0, k);
        Vector<double> col;
        if (row.active) {
          Vector<double> e(m.dof.n_dofs());
          for (std::size_t i = 0; i < row.dofs.size(); ++i) e[row.dofs[i]] = row.values[i];
          iterations += m.apply_inverse(e, col, opt);
        }
        it = m.columns.emplace(key, std::make_pair(std::move(row), std::move(col))).first;
      }
      // g of the cached row holds −c_D·u_D only; add the requested displacement now.
      const double g = points[k].displacement[c] + it->second.first.g;
      if (!it->second.first.active) {
        if (std::abs(g) > 1e-12 * (1.0 + std::abs(points[k].displacement[c]))) {
          std::ostringstream s;
          s << "point constraint " << k << " (component " << c
            << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
          throw std::invalid_argument(s.str());
        }
        continue;
      }
      rows.push_back({&it->second.first, &it->second.second, g, points[k].compliance[c], k, c});
    }
  return rows;
}

// S = C K⁻¹ Cᵀ + diag(κ) (symmetrised) and r = C u0 − g over all rows.
void schur_complement(const std::vector<SchurRow>& rows, const Vector<double>& u0, Eigen::MatrixXd& S,
                      Eigen::VectorXd& r) {
  const std::size_t n = rows.size();
  S.resize(n, n);
  r.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    const ConstraintRow& ra = *rows[a].row;
    double cu = 0.0;
    for (std::size_t i = 0; i < ra.dofs.size(); ++i) cu += ra.values[i] * u0[ra.dofs[i]];
    r[a] = cu - rows[a].g;
    for (std::size_t b = 0; b < n; ++b) {
      double v = 0.0;
      for (std::size_t i = 0; i < ra.dofs.size(); ++i) v += ra.values[i] * (*rows[b].col)[ra.dofs[i]];
      S(a, b) = v;
    }
  }
  S = 0.5 * (S + S.transpose()).eval();
  for (std::size_t a = 0; a < n; ++a) S(a, a) += rows[a].compliance;
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
  const Eigen::LLT<Eigen::MatrixXd> scaled(dinv.asDiagonal() * S * dinv.asDiagonal());
  const double rcond = scaled.info() == Eigen::Success ? scaled.rcond() : 0.0;
  if (!(rcond >= 1e-14)) {
    std::ostringstream s;
    s << "the " << nr << " point-constraint rows are nearly dependent (reciprocal condition number " << rcond
      << " of their Schur complement)";
    throw DependentPointConstraints(s.str());
  }
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
  m.ensure_mesh();
  m.prepare_solver(opt);
  Timer timer;
  unsigned iterations = 0;
  double residual = 0.0;
  if (!m.have_u0) {
    m.u0_iterations = m.apply_inverse(m.f, m.u0, opt, &residual);
    m.have_u0 = true;
  }
  iterations += m.u0_iterations;
  std::vector<SchurRow> rows = schur_rows<dim>(m, points, opt, iterations);
  RowSet all;
  for (const auto& r : rows) all.add(r.row, r.g, r.point, r.comp);
  Eigen::MatrixXd S_all;
  Eigen::VectorXd r_all;
  schur_complement(rows, m.u0, S_all, r_all);
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
      m.u.add(-x[a], *rows[a].col);
    }
  }
  double solve_seconds = 0.0;
  Solution<dim> s = finish_constrained_solve<dim>(m, all, keep, points.size(), timer, &solve_seconds);
  for (std::size_t a = 0; a < nr; ++a) {
    s.point_force[rows[a].point] -= mu[a] * points[rows[a].point].axes.col(rows[a].comp);
    add_constraint_reactions<dim>(m, *rows[a].row, mu[a], s);
  }
  s.stats.method = m.method;
  s.stats.constraint_rows = static_cast<unsigned>(nr);
  s.stats.dependent_rows_dropped = static_cast<unsigned>(n_all - nr);
  s.stats.iterations = iterations;
  s.stats.residual = residual;
  s.stats.solve_seconds = solve_seconds + m.prepare_seconds;
  s.stats.precondition_seconds = m.prepare_seconds;
  m.prepare_seconds = 0.0;  // count factorisation / AMG setup once
  return s;
}

// ================================================================================================
// solve_monolithic(): [K Cᵀ; C −diag(κ)] [u; μ] = [f; g] by UMFPACK

namespace {

// The saddle-point matrix of K and the rows, and its right-hand side [f; g].
template <int dim>
void saddle_point_system(const State<dim>& m, const std::vector<const ConstraintRow*>& rows,
                         SparsityPattern& sp, SparseMatrix<double>& A, Vector<double>& x) {
  const unsigned n = m.dof.n_dofs();
  const unsigned nr = static_cast<unsigned>(rows.size());
  DynamicSparsityPattern dsp(n + nr, n + nr);
  for (unsigned i = 0; i < n; ++i)
    for (auto it = m.sparsity.begin(i); it != m.sparsity.end(i); ++it) dsp.add(i, it->column());
  for (unsigned a = 0; a < nr; ++a) {
    for (auto d : rows[a]->dofs) dsp.add(n + a, d), dsp.add(d, n + a);
    dsp.add(n + a, n + a);  // −κ of a compliant row
  }
  sp.copy_from(dsp);
  A.reinit(sp);
  for (unsigned i = 0; i < n; ++i)
    for (auto it = m.K.begin(i); it != m.K.end(i); ++it) A.set(i, it->column(), it->value());
  x.reinit(n + nr);
  for (unsigned i = 0; i < n; ++i) x[i] = m.f[i];
  for (unsigned a = 0; a < nr; ++a) {
    for (std::size_t i = 0; i < rows[a]->dofs.size(); ++i) {
      A.set(n + a, rows[a]->dofs[i], rows[a]->values[i]);
      A.set(rows[a]->dofs[i], n + a, rows[a]->values[i]);
    }
    x[n + a] = rows[a]->g;
    if (rows[a]->compliance > 0.0) A.set(n + a, n + a, -rows[a]->compliance);
  }
}

}  // namespace

template <int dim>
Solution<dim> ElasticModel<dim>::solve_monolithic(const std::vector<PointConstraint<dim>>& points,
                                                  const SolverOptions& opt) {
  Impl& m = *impl_;
  check_points(points);
  m.ensure_mesh();
  m.assemble();
  Timer timer;
  const unsigned n = m.dof.n_dofs();
  std::vector<ConstraintRow> rows;
  RowSet all;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c)
      if (points[k].components[c]) {
        ConstraintRow row = constraint_row<dim>(m, points[k], c, points[k].displacement[c], k);
        if (row.active) rows.push_back(std::move(row)), all.which.emplace_back(k, c);
      }
  for (const auto& r : rows) all.rows.push_back(&r), all.g.push_back(r.g);
  const std::vector<bool> keep = independent_rows(all.rows);
  std::vector<const ConstraintRow*> used;
  std::vector<std::pair<std::size_t, unsigned>> used_which;
  for (std::size_t a = 0; a < rows.size(); ++a)
    if (keep[a]) used.push_back(all.rows[a]), used_which.push_back(all.which[a]);
  const unsigned nr = static_cast<unsigned>(used.size());
  SparsityPattern sp;
  SparseMatrix<double> A;
  Vector<double> x;
  saddle_point_system<dim>(m, used, sp, A, x);
  SparseDirectUMFPACK direct;
  direct.initialize(A);
  direct.solve(x);
  m.u.reinit(n);
  for (unsigned i = 0; i < n; ++i) m.u[i] = x[i];
  double solve_seconds = 0.0;
  Solution<dim> s = finish_constrained_solve<dim>(m, all, keep, points.size(), timer, &solve_seconds);
  for (unsigned a = 0; a < nr; ++a) {
    const auto [point, comp] = used_which[a];
    s.point_force[point] -= x[n + a] * points[point].axes.col(comp);
    add_constraint_reactions<dim>(m, *used[a], x[n + a], s);
  }
  s.stats.method = "umfpack-monolithic";
  s.stats.constraint_rows = nr;
  s.stats.dependent_rows_dropped = static_cast<unsigned>(rows.size() - nr);
  s.stats.solve_seconds = solve_seconds;
  (void)opt;
  return s;
}

#define VIM_FEM_SOLVERS(dim)                                                                           \
  template void ElasticModel<dim>::Impl::prepare_solver(const SolverOptions&);                         \
  template unsigned ElasticModel<dim>::Impl::apply_inverse(const Vector<double>&, Vector<double>&,     \
                                                           const SolverOptions&, double*) const;       \
  template Solution<dim> ElasticModel<dim>::solve(const std::vector<PointConstraint<dim>>&,            \
                                                  const SolverOptions&);                               \
  template Solution<dim> ElasticModel<dim>::solve_monolithic(const std::vector<PointConstraint<dim>>&, \
                                                             const SolverOptions&);
VIM_FEM_SOLVERS(2)
VIM_FEM_SOLVERS(3)

}  // namespace vim::fem

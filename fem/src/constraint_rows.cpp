// Rows of embedded point constraints (constraint_rows.hpp) and the monolithic saddle-point solve
// [K Cᵀ; C −diag(κ)] [u; μ] = [f; g] by UMFPACK, the reference for the condensed fast path (solvers.cpp).
#include "constraint_rows.hpp"

#include <deal.II/base/quadrature.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparse_direct.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <vim/point_text.hpp>

namespace vim::fem {

using namespace dealii;

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

// Adds w·a·N(x) (the stencil of x: the shape-function values of the cell containing it, along a) to
// `row`, Dirichlet DoFs moved to the right-hand side.
template <int dim>
void add_sample_to_row(const PointStencil& st, const Vec<dim>& a, double w, ConstraintRow& row,
                       double& scale) {
  for (const StencilDof& d : st.dofs) {
    const double v = w * a[d.comp] * d.shape;
    scale = std::max(scale, std::abs(v));
    if (v == 0.0) continue;
    if (d.bc >= 0) {  // for the reactions: the row's own coefficients on held DoFs
      row.dirichlet_values.push_back(v);
      row.dirichlet_bc.push_back(d.bc);
      row.dirichlet_comp.push_back(static_cast<unsigned char>(d.comp));
    }
    if (d.constrained) {
      // u_i = h + Σ a_f u_f (a support along other axes): h moves to g, v·a_f onto the free DoFs f.
      row.g -= v * d.inhomogeneity;
      for (const auto& [f, af] : d.entries) add_to_row(row, f, v * af);
    } else {
      add_to_row(row, d.dof, v);
    }
  }
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

}  // namespace

// Row of C for direction a (a unit vector; e_c for component c = axes.col(c)) of point constraint p:
// a·N at the point, or the weighted mean of a·N over its samples (those inside the mesh, renormalised),
// Dirichlet DoFs moved to the right-hand side. `c` only names the component in messages.
template <int dim>
ConstraintRow constraint_row(const State<dim>& m, const PointConstraint<dim>& p, unsigned c, double g,
                             std::size_t which, bool evaluation) {
  const Vec<dim> a = p.axes.col(c);
  auto samples = constraint_samples(p, which);
  std::vector<Vec<dim>> at(samples.size());
  for (std::size_t q = 0; q < samples.size(); ++q) at[q] = samples[q].first;
  const std::vector<PointStencil> st = m.stencils(at);
  double inside = 0.0;
  for (std::size_t q = 0; q < samples.size(); ++q)
    if (st[q].inside) inside += samples[q].second;
  if (!(inside > 0.0)) {
    std::ostringstream s;
    s << "point constraint " << which << " at " << point_text(p.position.data(), dim)
      << (p.offsets.empty() ? " lies outside the mesh" : ": all its averaging samples lie outside the mesh");
    throw std::invalid_argument(s.str());
  }
  ConstraintRow row;
  row.g = g;
  row.compliance = p.compliance[c];
  double scale = 0.0;
  for (std::size_t q = 0; q < samples.size(); ++q)
    if (st[q].inside) add_sample_to_row<dim>(st[q], a, samples[q].second / inside, row, scale);
  double free_scale = 0.0;
  for (double v : row.values) free_scale = std::max(free_scale, std::abs(v));
  if (!(free_scale > 1e-12 * scale)) {
    if (!evaluation && std::abs(row.g) > 1e-12 * (1.0 + std::abs(g))) {
      std::ostringstream s;
      s << "point constraint " << which << " at " << point_text(p.position.data(), dim) << " (component " << c
        << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
      throw std::invalid_argument(s.str());
    }
    row.active = false;
  }
  return row;
}

void check_scaled_schur(const Eigen::LLT<Eigen::MatrixXd>& scaled, Eigen::Index n) {
  const double rcond = scaled.info() == Eigen::Success ? scaled.rcond() : 0.0;
  if (rcond >= 1e-14) return;
  std::ostringstream s;
  s << "the " << n << " point-constraint rows are nearly dependent (reciprocal condition number " << rcond
    << " of their Schur complement)";
  throw DependentPointConstraints(s.str());
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
void add_constraint_reactions(const ConstraintRow& row, double mu, Solution<dim>& s) {
  for (std::size_t i = 0; i < row.dirichlet_values.size(); ++i)
    s.dirichlet_reaction[row.dirichlet_bc[i]][row.dirichlet_comp[i]] += mu * row.dirichlet_values[i];
}

// After a constrained solve of m.u (free DoFs): checks the dropped rows, distributes the Dirichlet
// values and post-processes; the point forces are left zero for the caller to fill in.
template <int dim>
Solution<dim> finish_constrained_solve(State<dim>& m, const RowSet& set, const std::vector<bool>& keep,
                                       std::size_t n_points, const Timer& timer, double* solve_seconds) {
  check_dropped_rows(set, keep, m.u);
  m.distribute_constraints(m.u);
  m.have_solution = true;
  *solve_seconds = timer.wall_time();
  Solution<dim> s = m.postprocess();
  s.point_force.assign(n_points, Vec<dim>::Zero());
  return s;
}

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
  check_points(points);
  Impl& m = *impl_;
  if (m.solves_over_ranks())
    throw std::invalid_argument(
        "solve_monolithic: the model's solves run over MPI ranks (distribute_solves); use solve()");
  m.ensure_mesh();
  m.assemble();
  m.assemble_matrices();
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
    add_constraint_reactions<dim>(*used[a], x[n + a], s);
  }
  s.stats.method = "umfpack-monolithic";
  s.stats.constraint_rows = nr;
  s.stats.dependent_rows_dropped = static_cast<unsigned>(rows.size() - nr);
  s.stats.solve_seconds = solve_seconds;
  (void)opt;
  return s;
}

#define VIM_FEM_CONSTRAINT_ROWS(dim)                                                                         \
  template ConstraintRow constraint_row<dim>(const State<dim>&, const PointConstraint<dim>&, unsigned,       \
                                             double, std::size_t, bool);                                     \
  template void check_points<dim>(const std::vector<PointConstraint<dim>>&);                                 \
  template void add_constraint_reactions<dim>(const ConstraintRow&, double, Solution<dim>&);                 \
  template Solution<dim> finish_constrained_solve<dim>(State<dim>&, const RowSet&, const std::vector<bool>&, \
                                                       std::size_t, const Timer&, double*);                  \
  template Solution<dim> ElasticModel<dim>::solve_monolithic(const std::vector<PointConstraint<dim>>&,       \
                                                             const SolverOptions&);
VIM_FEM_CONSTRAINT_ROWS(2)
VIM_FEM_CONSTRAINT_ROWS(3)

}  // namespace vim::fem
// A fixed set of point constraints condensed once (vim/fem/condensed_constraints.hpp): the same Schur
// complement, dropping rule and errors as ElasticModel::solve (solvers.cpp), on rows identified by
// index, in preallocated workspace.
#include <deal.II/base/timer.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vim/fem/condensed_constraints.hpp>

#include "constraint_rows.hpp"

namespace vim::fem {

using namespace dealii;

template <int dim>
struct CondensedConstraints<dim>::Impl {
  State<dim>* m = nullptr;
  std::size_t n_points = 0;
  // per row (selected component of a point, point-major)
  std::vector<const ColumnCache::Entry*> entry;
  std::vector<std::size_t> point;
  std::vector<unsigned> comp;
  std::vector<std::size_t> first_row;  // per point + 1: its rows are [first_row[p], first_row[p + 1])
  std::vector<Eigen::Matrix<double, dim, dim>> axes;  // per point
  Eigen::MatrixXd G;                                  // c_a K⁻¹ c_bᵀ (0 for void rows)
  Eigen::VectorXd cu0, g_dirichlet, kappa;            // c·u0, −c_D·u_D, κ per row
  // probes: rows of N_p along each axis
  Eigen::MatrixXd P;    // (probe, axis) × row: N_p·K⁻¹c_rowᵀ
  Eigen::VectorXd pu0;  // N_p·u0 with the Dirichlet values
  std::vector<Vec<dim>> probe_u;
  // the last solve: used rows (non-void rows of the active points, in order), kept ones, multipliers
  std::vector<Eigen::Index> used, kept;
  std::vector<double> g_used;
  std::vector<std::size_t> used_slot;  // index into `active` of each used row
  std::vector<bool> keep;
  std::size_t n_active = 0;
  Eigen::MatrixXd S, L;
  Eigen::VectorXd r, x, l;
  SolverStats stats;

  void gather(const std::vector<std::size_t>& active, const std::vector<Vec<dim>>& displacement);
  void factor_keep();
  void check_conditioning() const;
  void check_dropped() const;
  double held(Eigen::Index row) const;
};

template <int dim>
CondensedConstraints<dim>::CondensedConstraints(ElasticModel<dim>& model,
                                                const std::vector<PointConstraint<dim>>& points,
                                                const std::vector<Vec<dim>>& probes, const SolverOptions& opt)
    : impl_(std::make_unique<Impl>()) {
  Impl& c = *impl_;
  model.precompute(points, opt);  // checks the points, factorises K, caches the columns and u0
  State<dim>& m = ModelAccess::state(model);
  c.m = &m;
  c.n_points = points.size();
  const std::vector<ColumnCache::Entry*> entries = cached_rows<dim>(m, points, opt, nullptr, nullptr);
  c.first_row.push_back(0);
  for (std::size_t k = 0; k < points.size(); ++k) {
    c.axes.push_back(points[k].axes);
    for (unsigned d = 0; d < unsigned(dim); ++d)
      if (points[k].components[d]) c.point.push_back(k), c.comp.push_back(d);
    c.first_row.push_back(c.point.size());
  }
  const auto n = static_cast<Eigen::Index>(entries.size());
  c.entry.assign(entries.begin(), entries.end());
  c.G = Eigen::MatrixXd::Zero(n, n);
  c.cu0.resize(n), c.g_dirichlet.resize(n), c.kappa.resize(n);
  for (Eigen::Index a = 0; a < n; ++a) {
    c.cu0[a] = entries[a]->cu0;
    c.g_dirichlet[a] = entries[a]->row.g;
    c.kappa[a] = points[c.point[a]].compliance[c.comp[a]];
    for (Eigen::Index b = 0; b <= a && entries[a]->row.active; ++b)
      if (entries[b]->row.active) c.G(a, b) = c.G(b, a) = m.columns.product(*entries[a], *entries[b]);
  }
  const auto np = static_cast<Eigen::Index>(probes.size());
  c.P.resize(np * dim, n);
  c.pu0.resize(np * dim);
  for (Eigen::Index p = 0; p < np; ++p)
    for (int d = 0; d < dim; ++d) {
      PointConstraint<dim> at(probes[p]);
      const ConstraintRow row = constraint_row<dim>(m, at, d, 0.0, p, true);
      const auto dot = [&](const Vector<double>& v) {
        double s = 0.0;
        for (std::size_t i = 0; i < row.dofs.size(); ++i) s += row.values[i] * v[row.dofs[i]];
        return s;
      };
      c.pu0[p * dim + d] = dot(m.u0) - row.g;
      for (Eigen::Index a = 0; a < n; ++a)
        c.P(p * dim + d, a) = entries[a]->row.active ? dot(entries[a]->col) : 0.0;
    }
  c.probe_u.assign(probes.size(), Vec<dim>::Zero());
  for (Eigen::Index p = 0; p < np; ++p) c.probe_u[p] = c.pu0.template segment<dim>(p * dim);
  c.used.reserve(n), c.kept.reserve(n), c.g_used.reserve(n), c.used_slot.reserve(n), c.keep.reserve(n);
  c.S.resize(n, n), c.L.resize(n, n), c.r.resize(n), c.x.resize(n), c.l.resize(n);
  c.stats.method = m.method;
  c.stats.reason = m.method_reason;
  c.stats.n_dofs = static_cast<unsigned>(m.n_solve_dofs());
}

template <int dim>
CondensedConstraints<dim>::~CondensedConstraints() = default;
template <int dim>
CondensedConstraints<dim>::CondensedConstraints(CondensedConstraints&&) noexcept = default;

template <int dim>
std::size_t CondensedConstraints<dim>::n_points() const {
  return impl_->n_points;
}
template <int dim>
std::size_t CondensedConstraints<dim>::n_rows() const {
  return impl_->entry.size();
}

// The non-void rows of the active points with their right-hand sides (void rows checked as solve() does),
// S over them with the compliances on the diagonal, and r = C u0 − g.
template <int dim>
void CondensedConstraints<dim>::Impl::gather(const std::vector<std::size_t>& active,
                                             const std::vector<Vec<dim>>& displacement) {
  used.clear(), g_used.clear(), used_slot.clear();
  for (std::size_t i = 0; i < active.size(); ++i) {
    if (active[i] >= n_points) throw std::invalid_argument("CondensedConstraints: point index out of range");
    if (!displacement[i].allFinite())
      throw std::invalid_argument("point constraint " + std::to_string(i) + " has a non-finite displacement");
    for (std::size_t a = first_row[active[i]]; a < first_row[active[i] + 1]; ++a) {
      const double want = displacement[i][comp[a]];
      const double g = want + g_dirichlet[static_cast<Eigen::Index>(a)];
      if (!entry[a]->row.active) {
        check_void_row(g, want, i, comp[a]);
        continue;
      }
      used.push_back(static_cast<Eigen::Index>(a));
      g_used.push_back(g);
      used_slot.push_back(i);
    }
  }
  const auto nu = static_cast<Eigen::Index>(used.size());
  for (Eigen::Index a = 0; a < nu; ++a) {
    r[a] = cu0[used[a]] - g_used[a];
    for (Eigen::Index b = 0; b < nu; ++b) S(a, b) = G(used[a], used[b]);
    S(a, a) += kappa[used[a]];
  }
}

// The ordered Cholesky of ElasticModel::solve: row a is dropped when its pivot vanishes (a combination of
// the earlier kept rows); L holds the factor of the kept rows.
template <int dim>
void CondensedConstraints<dim>::Impl::factor_keep() {
  const auto nu = static_cast<Eigen::Index>(used.size());
  kept.clear();
  keep.assign(used.size(), false);
  for (Eigen::Index a = 0; a < nu; ++a) {
    const auto k = static_cast<Eigen::Index>(kept.size());
    for (Eigen::Index i = 0; i < k; ++i) {
      double v = S(kept[i], a);
      for (Eigen::Index j = 0; j < i; ++j) v -= L(i, j) * l[j];
      l[i] = v / L(i, i);
    }
    const double d = S(a, a) - l.head(k).squaredNorm();
    if (!(S(a, a) > 0.0) || !(d > 1e-10 * S(a, a))) continue;
    keep[static_cast<std::size_t>(a)] = true;
    for (Eigen::Index j = 0; j < k; ++j) L(k, j) = l[j];
    L(k, k) = std::sqrt(d);
    kept.push_back(a);
  }
}

// ElasticModel::solve's conditioning test on the kept rows' S scaled to a unit diagonal (reciprocal
// condition number ≥ 1e-14). With positive compliances the scaled S ≥ diag(κ_a / S_aa) has
// λ_min ≥ min κ_a/S_aa, its 1-norm ≤ n and so rcond₁ ≥ λ_min / n^1.5: when that bound passes no
// estimate (and no allocation) is needed.
template <int dim>
void CondensedConstraints<dim>::Impl::check_conditioning() const {
  const auto nk = static_cast<Eigen::Index>(kept.size());
  if (nk == 0) return;
  double lambda_min = std::numeric_limits<double>::infinity();
  for (Eigen::Index a = 0; a < nk; ++a)
    lambda_min = std::min(lambda_min, kappa[used[kept[a]]] / S(kept[a], kept[a]));
  if (lambda_min / std::pow(static_cast<double>(nk), 1.5) >= 1e-14) return;
  Eigen::MatrixXd Sk(nk, nk);
  for (Eigen::Index a = 0; a < nk; ++a)
    for (Eigen::Index b = 0; b < nk; ++b)
      Sk(a, b) = S(kept[a], kept[b]) / std::sqrt(S(kept[a], kept[a]) * S(kept[b], kept[b]));
  check_scaled_schur(Eigen::LLT<Eigen::MatrixXd>(Sk), nk);
}

// The value c·u of a row (the displacement it holds, Dirichlet part included) in the last solution.
template <int dim>
double CondensedConstraints<dim>::Impl::held(Eigen::Index row) const {
  double v = cu0[row] - g_dirichlet[row];
  for (std::size_t b = 0; b < kept.size(); ++b) v -= G(row, used[kept[b]]) * x[static_cast<Eigen::Index>(b)];
  return v;
}

// A dropped row must hold anyway (ElasticModel::solve's check; the scale here is the largest right-hand
// side or held value instead of the largest DoF value).
template <int dim>
void CondensedConstraints<dim>::Impl::check_dropped() const {
  double scale = 0.0;
  for (std::size_t a = 0; a < used.size(); ++a)
    scale = std::max({scale, std::abs(g_used[a] - g_dirichlet[used[a]]), std::abs(held(used[a]))});
  for (std::size_t a = 0; a < used.size(); ++a) {
    if (keep[a]) continue;
    const double misfit = held(used[a]) - (g_used[a] - g_dirichlet[used[a]]);
    if (std::abs(misfit) > 1e-8 * scale) {
      std::ostringstream s;
      s << "point constraint " << used_slot[a] << " (component " << comp[static_cast<std::size_t>(used[a])]
        << ") conflicts with earlier point constraints: it is a linear combination of them but asks for a "
           "different displacement (misfit "
        << misfit << ")";
      throw DependentPointConstraints(s.str());
    }
  }
}

template <int dim>
void CondensedConstraints<dim>::solve(const std::vector<std::size_t>& active,
                                      const std::vector<Vec<dim>>& displacement) {
  Impl& c = *impl_;
  if (displacement.size() < active.size())
    throw std::invalid_argument("CondensedConstraints::solve: one displacement per active point");
  c.n_active = active.size();
  c.kept.clear();
  c.gather(active, displacement);
  c.factor_keep();
  c.check_conditioning();
  const auto nk = static_cast<Eigen::Index>(c.kept.size());
  for (Eigen::Index a = 0; a < nk; ++a) c.x[a] = c.r[c.kept[a]];
  const auto Lk = c.L.topLeftCorner(nk, nk);
  auto xk = c.x.head(nk);
  Lk.template triangularView<Eigen::Lower>().solveInPlace(xk);
  Lk.transpose().template triangularView<Eigen::Upper>().solveInPlace(xk);
  c.check_dropped();
  for (std::size_t p = 0; p < c.probe_u.size(); ++p) {
    Vec<dim> u = c.pu0.template segment<dim>(static_cast<Eigen::Index>(p * dim));
    for (Eigen::Index a = 0; a < nk; ++a)
      u -= c.P.template block<dim, 1>(static_cast<Eigen::Index>(p * dim), c.used[c.kept[a]]) * c.x[a];
    c.probe_u[p] = u;
  }
  c.stats.constraint_rows = static_cast<unsigned>(nk);
  c.stats.dependent_rows_dropped = static_cast<unsigned>(c.used.size() - c.kept.size());
}

template <int dim>
void CondensedConstraints<dim>::point_forces(std::vector<Vec<dim>>& force) const {
  const Impl& c = *impl_;
  force.assign(c.n_active, Vec<dim>::Zero());
  for (std::size_t a = 0; a < c.kept.size(); ++a) {
    const auto row = static_cast<std::size_t>(c.used[c.kept[a]]);
    force[c.used_slot[c.kept[a]]] -=
        c.x[static_cast<Eigen::Index>(a)] * c.axes[c.point[row]].col(c.comp[row]);
  }
}

template <int dim>
const std::vector<Vec<dim>>& CondensedConstraints<dim>::probe_displacements() const {
  return impl_->probe_u;
}

template <int dim>
Vec<dim> CondensedConstraints<dim>::held_displacement(std::size_t point) const {
  const Impl& c = *impl_;
  Vec<dim> u = Vec<dim>::Zero();
  for (std::size_t a = c.first_row.at(point); a < c.first_row[point + 1]; ++a)
    u += c.held(static_cast<Eigen::Index>(a)) * c.axes[point].col(c.comp[a]);
  return u;
}

template <int dim>
const SolverStats& CondensedConstraints<dim>::stats() const {
  return impl_->stats;
}

template <int dim>
Solution<dim> CondensedConstraints<dim>::field() {
  Impl& c = *impl_;
  State<dim>& m = *c.m;
  Timer timer;
  m.u = m.u0;
  for (std::size_t a = 0; a < c.kept.size(); ++a)
    m.u.add(-c.x[static_cast<Eigen::Index>(a)], c.entry[static_cast<std::size_t>(c.used[c.kept[a]])]->col);
  RowSet all;
  for (std::size_t a = 0; a < c.used.size(); ++a) {
    const auto row = static_cast<std::size_t>(c.used[a]);
    all.add(&c.entry[row]->row, c.g_used[a], c.used_slot[a], c.comp[row]);
  }
  double solve_seconds = 0.0;
  Solution<dim> s = finish_constrained_solve<dim>(m, all, c.keep, c.n_active, timer, &solve_seconds);
  point_forces(s.point_force);
  for (std::size_t a = 0; a < c.kept.size(); ++a)
    add_constraint_reactions<dim>(c.entry[static_cast<std::size_t>(c.used[c.kept[a]])]->row,
                                  c.x[static_cast<Eigen::Index>(a)], s);
  s.stats = c.stats;
  s.stats.solve_seconds = solve_seconds;
  return s;
}

template class CondensedConstraints<2>;
template class CondensedConstraints<3>;

}  // namespace vim::fem

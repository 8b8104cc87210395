// Internal to vim_fem (deal.II inside): the rows C u = g of embedded point constraints, shared by the
// two constrained solves — solve() (Schur complement over cached columns, solvers.cpp) and
// solve_monolithic() (the saddle-point reference, constraint_rows.cpp).
#pragma once

#include <deal.II/base/timer.h>
#include <deal.II/lac/vector.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "model_state.hpp"

namespace vim::fem {

template <int dim>
using State = ModelAccess::State<dim>;

// Row of C for direction axes.col(c) of point constraint p (`which` its index, for messages): a·N at the
// point, or the weighted mean of a·N over its samples inside the mesh, Dirichlet DoFs moved to the
// right-hand side g (which starts at `g`). Throws std::invalid_argument for a point (or all its
// samples) outside the mesh, or (unless `evaluation`: a row that only evaluates the field there) one on
// Dirichlet nodes asking for another displacement.
template <int dim>
ConstraintRow constraint_row(const State<dim>& m, const PointConstraint<dim>& p, unsigned c, double g,
                             std::size_t which, bool evaluation = false);

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

// Of the column cache (solvers.cpp): the cache key of direction `dir` of p (position, direction, then
// the sample offsets and weights), and the entries of the rows of `points` (one per selected component,
// point-major), the rows not cached yet computed first in one batch of right-hand sides (their CG
// iterations added to *iterations, their number to *computed; either may be null).
template <int dim>
ColumnCache::Key column_key(const PointConstraint<dim>& p, const Vec<dim>& dir);
template <int dim>
std::vector<ColumnCache::Entry*> cached_rows(State<dim>& m, const std::vector<PointConstraint<dim>>& points,
                                             const SolverOptions& opt, unsigned* iterations,
                                             unsigned* computed);

// A void row (its point on Dirichlet-constrained DoFs only) with right-hand side g: std::invalid_argument
// naming point `which`, component c unless g vanishes (relative to the requested displacement).
inline void check_void_row(double g, double displacement, std::size_t which, unsigned c) {
  if (std::abs(g) <= 1e-12 * (1.0 + std::abs(displacement))) return;
  std::ostringstream s;
  s << "point constraint " << which << " (component " << c
    << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
  throw std::invalid_argument(s.str());
}

// Throws DependentPointConstraints when the Cholesky factor `scaled` of the n point-constraint rows'
// Schur complement scaled to a unit diagonal has a reciprocal condition number below 1e-14 (or failed):
// the solve's error bound n·ε/rcond then exceeds 10% for a few dozen rows (solvers.cpp, solve_schur).
void check_scaled_schur(const Eigen::LLT<Eigen::MatrixXd>& scaled, Eigen::Index n);

// Throws std::invalid_argument for non-finite positions/displacements, negative compliances or axes
// that are not orthonormal.
template <int dim>
void check_points(const std::vector<PointConstraint<dim>>& points);

// Adds the Dirichlet part of a row with multiplier mu to the support reactions of s.
template <int dim>
void add_constraint_reactions(const ConstraintRow& row, double mu, Solution<dim>& s);

// After a constrained solve of m.u (free DoFs): checks the dropped rows (DependentPointConstraints when
// one does not hold), distributes the Dirichlet values and post-processes; the point forces are left
// zero for the caller to fill in.
template <int dim>
Solution<dim> finish_constrained_solve(State<dim>& m, const RowSet& set, const std::vector<bool>& keep,
                                       std::size_t n_points, const dealii::Timer& timer,
                                       double* solve_seconds);

// The ordered Cholesky of the rows' Schur complement S (ElasticModel::solve's rule): row a is dropped
// when its pivot vanishes (a combination of the earlier kept rows); solve() gives 0 on dropped rows.
struct KeptCholesky {
  std::vector<Eigen::Index> kept;
  Eigen::MatrixXd L;
  void factor(const Eigen::MatrixXd& S) {
    const Eigen::Index n = S.rows();
    kept.clear();
    L.setZero(n, n);
    Eigen::VectorXd l(n);
    for (Eigen::Index a = 0; a < n; ++a) {
      const auto k = static_cast<Eigen::Index>(kept.size());
      for (Eigen::Index i = 0; i < k; ++i) {
        double v = S(kept[static_cast<std::size_t>(i)], a);
        for (Eigen::Index j = 0; j < i; ++j) v -= L(i, j) * l[j];
        l[i] = v / L(i, i);
      }
      const double d = S(a, a) - l.head(k).squaredNorm();
      if (!(S(a, a) > 0.0) || !(d > 1e-10 * S(a, a))) continue;
      for (Eigen::Index j = 0; j < k; ++j) L(k, j) = l[j];
      L(k, k) = std::sqrt(d);
      kept.push_back(a);
    }
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const {
    const auto k = static_cast<Eigen::Index>(kept.size());
    Eigen::VectorXd y(k), x = Eigen::VectorXd::Zero(b.size());
    for (Eigen::Index i = 0; i < k; ++i) y[i] = b[kept[static_cast<std::size_t>(i)]];
    const auto Lk = L.topLeftCorner(k, k);
    Lk.triangularView<Eigen::Lower>().solveInPlace(y);
    Lk.transpose().triangularView<Eigen::Upper>().solveInPlace(y);
    for (Eigen::Index i = 0; i < k; ++i) x[kept[static_cast<std::size_t>(i)]] = y[i];
    return x;
  }
};

// c·U of a row built with g = 0 (its Dirichlet part row.g = −c_D·u_D at full load, scaled by t).
inline double row_value(const ConstraintRow& row, const dealii::Vector<double>& U, double t) {
  double v = -t * row.g;
  for (std::size_t i = 0; i < row.dofs.size(); ++i) v += row.values[i] * U[row.dofs[i]];
  return v;
}
inline void add_row(const ConstraintRow& row, double a, dealii::Vector<double>& v) {
  for (std::size_t i = 0; i < row.dofs.size(); ++i) v[row.dofs[i]] += a * row.values[i];
}
inline double row_dot(const ConstraintRow& row, const double* x) {
  double v = 0.0;
  for (std::size_t i = 0; i < row.dofs.size(); ++i) v += row.values[i] * x[row.dofs[i]];
  return v;
}

}  // namespace vim::fem

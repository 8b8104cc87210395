// Finite-strain statics (vim/fem/finite_strain.hpp; docs/finite-strain.md): the neo-Hookean material
// of neo_hookean_material.hpp on the model's mesh, DoFs, quadrature and conditions, total Lagrangian.
// Residual r(U) = ∫ P(F) : ∇v dV + K_s U − t f (f the model's dead loads, K_s its volume supports),
// tangent ∂r/∂U = ∫ ∇v : A : ∇δu dV + K_s; Newton with CHOLMOD on the tangent with the Dirichlet
// conditions eliminated, a backtracking line search on ‖r‖, and load steps halved when they fail.
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <vim/fem/finite_strain.hpp>
#include <vim/fem/finite_strain_rows.hpp>

#include "constraint_rows.hpp"
#include "neo_hookean_material.hpp"
#include "newton_system.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

// Von Mises of a dim×dim Cauchy stress with σ₃₃ (plane strain) or of the 3×3 stress.
inline double von_mises(const Eigen::Matrix3d& s) {
  const double d = (s(0, 0) - s(1, 1)) * (s(0, 0) - s(1, 1)) + (s(1, 1) - s(2, 2)) * (s(1, 1) - s(2, 2)) +
                   (s(2, 2) - s(0, 0)) * (s(2, 2) - s(0, 0));
  return std::sqrt(0.5 * d + 3.0 * (s(0, 1) * s(0, 1) + s(1, 2) * s(1, 2) + s(0, 2) * s(0, 2)));
}

// The finite-strain fields of U at the cell centroids, the energy ∫ W dV and the reactions.
template <int dim>
void finite_strain_fields(State<dim>& m, const NeoHookeanMaterial<dim>& law, const Vector<double>& U,
                          double t, Solution<dim>& s) {
  const unsigned dpc = m.fe->n_dofs_per_cell();
  Quadrature<dim> cq(std::vector<Point<dim>>{m.unit_centroid});
  FEValues<dim> cv(*m.mapping, *m.fe, cq, update_gradients);
  auto fv = m.make_fe_values();
  std::vector<types::global_dof_index> idx(dpc);
  Vector<double> f_int(U.size()), Re(dpc);
  s.strain_energy = 0.0;
  const auto grad_u = [&](const FEValues<dim>& v, unsigned q) {
    Tensor<2, dim> H;
    for (unsigned i = 0; i < dpc; ++i)
      H[m.fe->system_to_component_index(i).first] += U[idx[i]] * v.shape_grad(i, q);
    return H;
  };
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    const unsigned j = cell->material_id();
    cv.reinit(cell);
    const Tensor<2, dim> H = grad_u(cv, 0);
    const Tensor<2, dim> F = Physics::Elasticity::Kinematics::F(H), sigma = law.cauchy_stress(j, H);
    const Tensor<2, dim> E = 0.5 * (transpose(F) * F - unit_symmetric_tensor<dim>());
    Eigen::Matrix3d s3 = Eigen::Matrix3d::Zero();
    for (int a = 0; a < dim; ++a)
      for (int b = 0; b < dim; ++b)
        s.cell_strain[j](a, b) = E[a][b], s.cell_stress[j](a, b) = s3(a, b) = sigma[a][b];
    if (dim == 2) s3(2, 2) = law.out_of_plane_stress(j, H);
    s.von_mises[j] = von_mises(s3);
    fv->reinit(cell);
    Re = 0.0;
    for (unsigned q = 0; q < fv->n_quadrature_points; ++q) {
      const Tensor<2, dim> Hq = grad_u(*fv, q);
      s.strain_energy += law.energy_density(j, Hq) * fv->JxW(q);
      const Tensor<2, dim> P = law.stress(j, Hq);
      for (unsigned i = 0; i < dpc; ++i)
        Re(i) += (P[m.fe->system_to_component_index(i).first] * fv->shape_grad(i, q)) * fv->JxW(q);
    }
    f_int.add(idx, Re);
  }
  s.dirichlet_reaction.assign(m.bcs.size(), Vec<dim>::Zero());
  for (unsigned i = 0; i < U.size(); ++i)
    if (m.dof_bc[i] >= 0) s.dirichlet_reaction[m.dof_bc[i]][m.dof_component[i]] += f_int[i] - t * m.f_full[i];
}

// One load step from U (converged at the previous load factor) to load factor t: false if Newton
// fails (no convergence, an inverted point, a tangent that is not positive definite).
template <int dim>
bool load_step(const NewtonSystem<dim>& sys, const NewtonOptions& opt, double t, Vector<double>& U,
               LoadStepRecord& rec) {
  rec = LoadStepRecord{};
  rec.load_factor = t;
  Vector<double> r, r_trial;
  SparseMatrix<double> K;
  if (!sys.assemble(U, t, r, &K)) return false;
  double r0 = 0.0, norm = sys.free_norm(r);
  for (unsigned it = 0; it < opt.max_iterations; ++it) {
    const Vector<double> g = sys.condition_gap(U, t);
    const bool moves_conditions = g.linfty_norm() > 0.0;
    double rhs_norm = 0.0;
    Vector<double> du;
    try {
      du = sys.update(K, r, g, &rhs_norm);
    } catch (const std::runtime_error&) {
      return false;
    }
    if (it == 0) r0 = std::max(rhs_norm, norm);
    if (r0 == 0.0) return true;  // nothing to do: the state is already in equilibrium
    rec.residual_norm.push_back(it == 0 ? r0 : norm);
    // Backtracking on ‖r‖ (the step that moves the conditions is taken whole: it must reach them).
    double alpha = 1.0, trial_norm = 0.0;
    Vector<double> trial;
    for (;;) {
      trial = U;
      trial.add(alpha, du);
      if (moves_conditions) sys.impose(trial, t);
      const bool valid = sys.assemble(trial, t, r_trial, nullptr);
      trial_norm = valid ? sys.free_norm(r_trial) : 0.0;
      if (valid && (moves_conditions || trial_norm < norm || norm < 1e-6 * r0)) break;
      if (moves_conditions || alpha < 1.0 / 64) return false;
      alpha *= 0.5;
    }
    rec.update_norm.push_back(alpha * du.l2_norm());
    rec.line_search.push_back(alpha);
    U = trial;
    norm = trial_norm;
    if (norm <= opt.tolerance * r0 && !moves_conditions) {
      rec.residual_norm.push_back(norm);
      return true;
    }
    if (!sys.assemble(U, t, r, &K)) return false;
  }
  return false;
}

}  // namespace

template <int dim>
FiniteStrainSolution<dim> solve_neo_hookean(ElasticModel<dim>& model, const NewtonOptions& opt) {
  State<dim>& m = ModelAccess::state(model);
  if (!(opt.tolerance > 0.0) || opt.max_iterations == 0 || opt.initial_steps == 0)
    throw std::invalid_argument(
        "NewtonOptions: tolerance must be > 0, max_iterations and initial_steps >= 1");
  if (m.solves_over_ranks()) throw std::invalid_argument("solve_neo_hookean: serial models only");
  m.ensure_mesh();
  m.assemble();
  const NewtonSystem<dim> sys(m);
  FiniteStrainSolution<dim> out;
  Vector<double> U(m.dof.n_dofs()), saved;
  const double full_step = 1.0 / opt.initial_steps;
  double t = 0.0, dt = full_step;
  unsigned in_row = 0;
  while (t < 1.0) {
    const double t_next = (1.0 - t) <= dt * (1.0 + 1e-12) ? 1.0 : t + dt;
    saved = U;
    LoadStepRecord rec;
    if (load_step(sys, opt, t_next, U, rec)) {
      out.newton_iterations += static_cast<unsigned>(rec.update_norm.size());
      out.steps.push_back(std::move(rec));
      t = t_next;
      in_row = 0;
      dt = std::min(2.0 * dt, full_step);
      continue;
    }
    U = saved;
    if (++in_row > opt.max_halvings) {
      std::ostringstream msg;
      msg << "neo-Hookean solve: the load step from load factor " << t << " to " << t_next
          << " did not converge after " << opt.max_halvings << " halvings (Newton: " << opt.max_iterations
          << " iterations, tolerance " << opt.tolerance << ")";
      throw NewtonFailure(msg.str());
    }
    ++out.halvings;
    dt *= 0.5;
  }
  m.u = U;
  m.have_solution = true;
  m.grid_vertex_u.clear();
  out.solution = m.postprocess();
  finite_strain_fields<dim>(m, sys.law(), U, 1.0, out.solution);
  out.solution.stats.method = "newton+cholmod";
  out.solution.stats.iterations = out.newton_iterations;
  return out;
}

template <int dim>
void neo_hookean_system(ElasticModel<dim>& model, const Eigen::VectorXd& u, double load_factor,
                        Eigen::VectorXd& residual, Eigen::MatrixXd& tangent) {
  State<dim>& m = ModelAccess::state(model);
  m.ensure_mesh();
  m.assemble();
  const NewtonSystem<dim> sys(m);
  const unsigned n = m.dof.n_dofs();
  if (u.size() != n) throw std::invalid_argument("neo_hookean_system: u has the wrong size");
  Vector<double> U(n), r;
  for (unsigned i = 0; i < n; ++i) U[i] = u[i];
  SparseMatrix<double> K;
  if (!sys.assemble(U, load_factor, r, &K)) throw std::invalid_argument("neo_hookean_system: J <= 0 at u");
  residual.resize(n);
  tangent.setZero(n, n);
  for (unsigned i = 0; i < n; ++i) {
    residual[i] = r[i];
    for (auto it = K.begin(i); it != K.end(i); ++it) tangent(i, it->column()) += it->value();
  }
}

// ---- point-constraint rows on the finite-strain model (vim/fem/finite_strain_rows.hpp) -------------

template <int dim>
struct FiniteStrainRows<dim>::Impl {
  State<dim>* m = nullptr;
  NewtonOptions opt;
  std::unique_ptr<NewtonSystem<dim>> sys;
  std::vector<ConstraintRow> rows, probe_rows;  // per (point, selected component); per (probe, axis)
  std::vector<std::size_t> first_row, point;
  std::vector<unsigned> comp;
  std::vector<Eigen::Matrix<double, dim, dim>> axes;
  std::vector<Vec<dim>> probe_u;
  Vector<double> U;
  double t = 0.0;  // the load factor of U (1 once the first solve has converged)
  // the last solve: its rows (indices into rows), their slot in `active`, multipliers
  std::vector<std::size_t> used, used_slot;
  std::vector<double> mu, mu_all;  // mu per used row; mu_all per row (0 where not used)
  std::size_t n_active = 0;
  std::vector<LoadStepRecord> steps;
  unsigned halvings = 0;
  SolverStats stats;
  // The factorised tangent (of U when factor_at_U, else of an earlier state: Newton then iterates with
  // it while it contracts the residual by 10 per iteration) and its columns K⁻¹cᵀ per row.
  std::unique_ptr<CholmodLLT> factor;
  bool factor_at_U = false;
  std::vector<long> column_of;  // per row: its column in `columns`, or −1
  std::vector<double> columns;
  bool have_tangent = false;  // `tangent` holds S of the used rows at U
  KeptCholesky tangent;

  // Assembles the tangent at X (load factor tt) and factorises it, with the condensed right-hand side
  // −(r + K gD) in rhs; false if some point of X has J ≤ 0 or K is not positive definite.
  bool refactor(const Vector<double>& X, double tt, const Vector<double>& gD, Vector<double>& rhs) {
    Vector<double> r;
    SparseMatrix<double> K;
    if (!sys->assemble(X, tt, r, &K)) return false;
    for (std::size_t a = 0; a < used.size(); ++a) add_row(rows[used[a]], mu[a], r);
    try {
      factor = sys->factorise(K, r, gD, rhs);
    } catch (const std::runtime_error&) {
      return false;  // the old factor is kept (see newton)
    }
    column_of.assign(rows.size(), -1);
    columns.clear();
    return true;
  }
  // S = C K⁻¹ Cᵀ + diag(κ) over the used rows, their columns solved with `factor` where not cached.
  Eigen::MatrixXd schur() {
    const std::size_t n = U.size();
    std::vector<std::size_t> missing;
    for (std::size_t a : used)
      if (column_of[a] < 0) missing.push_back(a);
    if (!missing.empty()) {
      const std::size_t first = columns.size() / n;
      columns.resize(columns.size() + missing.size() * n, 0.0);
      Vector<double> c(n);
      for (std::size_t k = 0; k < missing.size(); ++k) {
        c = 0.0;
        add_row(rows[missing[k]], 1.0, c);
        sys->condense(c);
        std::copy(c.begin(), c.end(), columns.begin() + static_cast<std::ptrdiff_t>((first + k) * n));
        column_of[missing[k]] = static_cast<long>(first + k);
      }
      factor->solve(columns.data() + first * n, missing.size());
    }
    const auto ni = static_cast<Eigen::Index>(used.size());
    Eigen::MatrixXd S(ni, ni);
    for (Eigen::Index a = 0; a < ni; ++a)
      for (Eigen::Index b = 0; b < ni; ++b)
        S(a, b) = row_dot(rows[used[static_cast<std::size_t>(a)]], column(used[static_cast<std::size_t>(b)]));
    S = (0.5 * (S + S.transpose())).eval();
    for (Eigen::Index a = 0; a < ni; ++a) S(a, a) += rows[used[static_cast<std::size_t>(a)]].compliance;
    return S;
  }
  const double* column(std::size_t row) const {
    return columns.data() + static_cast<std::size_t>(column_of[row]) * U.size();
  }
  // One continuation step to load factor tt with the used rows at targets gt and the rows left out
  // carrying the dead multipliers `dead`: Newton on (U, mu); false if it fails.
  bool newton(double tt, const std::vector<double>& gt,
              const std::vector<std::pair<std::size_t, double>>& dead, LoadStepRecord& rec);
};

template <int dim>
bool FiniteStrainRows<dim>::Impl::newton(double tt, const std::vector<double>& gt,
                                         const std::vector<std::pair<std::size_t, double>>& dead,
                                         LoadStepRecord& rec) {
  const std::size_t nu = used.size(), n = U.size();
  const auto residual = [&](const Vector<double>& X, const std::vector<double>& mx, Vector<double>& r) {
    if (!sys->assemble(X, tt, r, nullptr)) return false;
    for (std::size_t a = 0; a < nu; ++a) add_row(rows[used[a]], mx[a], r);
    for (const auto& [row, md] : dead) add_row(rows[row], md, r);
    return true;
  };
  const auto scale = [&](const std::vector<double>& mx) {  // the rows' and loads' forces on the free DoFs
    Vector<double> f(n);
    f.add(tt, m->f_full);
    for (std::size_t a = 0; a < nu; ++a) add_row(rows[used[a]], mx[a], f);
    return sys->free_norm(f);
  };
  Vector<double> r, r_trial, rhs;
  if (!residual(U, mu, r)) return false;
  double norm = sys->free_norm(r), r0 = 0.0;
  bool fresh = false;
  for (unsigned it = 0; it < opt.max_iterations; ++it) {
    const Vector<double> gD = sys->condition_gap(U, tt);
    const bool whole = it == 0;  // the first iteration moves the conditions and the rows: taken whole
    // A fresh tangent when the conditions move, when there is none, or after a slow contraction (then,
    // if the tangent at U is not positive definite by itself, the last one is kept).
    const bool moves = gD.linfty_norm() > 0.0;
    if ((moves || !factor || fresh) && refactor(U, tt, gD, rhs)) {
      for (const auto& [row, md] : dead) add_row(rows[row], -md, rhs);  // refactor's rhs lacks them
      factor_at_U = true;
    } else if (moves || !factor) {
      return false;
    } else {
      rhs = r;
      rhs *= -1.0;
      sys->condense(rhs);
    }
    const double rhs_norm = rhs.l2_norm();
    factor->solve(rhs.data());
    const auto ni = static_cast<Eigen::Index>(nu);
    const Eigen::MatrixXd S = schur();
    Eigen::VectorXd b(ni);
    for (std::size_t a = 0; a < nu; ++a)  // C K⁻¹ r₁ + r₂, r₂ = C U − κ μ − g
      b[static_cast<Eigen::Index>(a)] = row_dot(rows[used[a]], rhs.data()) + row_value(rows[used[a]], U, tt) -
                                        rows[used[a]].compliance * mu[a] - gt[a];
    KeptCholesky kc;
    kc.factor(S);
    const Eigen::VectorXd dmu = kc.solve(b);
    Vector<double> du(rhs);
    for (std::size_t a = 0; a < nu; ++a) {
      const double* col = column(used[a]);
      for (std::size_t i = 0; i < n; ++i) du[i] -= col[i] * dmu[static_cast<Eigen::Index>(a)];
    }
    sys->distribute(du);
    du += gD;
    if (it == 0) r0 = std::max(rhs_norm, norm);
    rec.residual_norm.push_back(norm);
    double alpha = 1.0, trial_norm = 0.0;
    Vector<double> trial;
    std::vector<double> mu_trial(nu);
    for (;;) {
      trial = U;
      trial.add(alpha, du);
      if (whole) sys->impose(trial, tt);
      for (std::size_t a = 0; a < nu; ++a) mu_trial[a] = mu[a] + alpha * dmu[static_cast<Eigen::Index>(a)];
      const bool valid = residual(trial, mu_trial, r_trial);
      trial_norm = valid ? sys->free_norm(r_trial) : 0.0;
      if (valid && (whole || trial_norm < norm || norm <= 1e-6 * r0)) break;
      if (whole || alpha < 1.0 / 64) return false;
      alpha *= 0.5;
    }
    rec.update_norm.push_back(alpha * du.l2_norm());
    rec.line_search.push_back(alpha);
    const double previous = norm;
    U = trial, mu = mu_trial, r = r_trial, norm = trial_norm;
    factor_at_U = false;
    const double ref = std::max(r0, scale(mu));
    // converged; or at the round-off floor of the residual (a tiny load: it no longer falls, 1e-6 below)
    const bool floor = norm <= 1e-6 * ref && norm > 0.5 * previous;
    if (!whole && (ref == 0.0 || norm <= opt.tolerance * ref || floor)) {
      rec.residual_norm.push_back(norm);
      return true;
    }
    fresh = !whole && norm > 0.1 * previous;  // slow contraction: a fresh tangent
  }
  return false;
}

template <int dim>
FiniteStrainRows<dim>::FiniteStrainRows(ElasticModel<dim>& model,
                                        const std::vector<PointConstraint<dim>>& points,
                                        const std::vector<Vec<dim>>& probes, const NewtonOptions& opt)
    : impl_(std::make_unique<Impl>()) {
  Impl& c = *impl_;
  c.m = &ModelAccess::state(model);
  State<dim>& m = *c.m;
  if (m.solves_over_ranks()) throw std::invalid_argument("FiniteStrainRows: serial models only");
  check_points<dim>(points);
  m.ensure_mesh();
  m.assemble();
  c.opt = opt;
  c.sys = std::make_unique<NewtonSystem<dim>>(m);
  c.first_row.push_back(0);
  for (std::size_t k = 0; k < points.size(); ++k) {
    c.axes.push_back(points[k].axes);
    for (unsigned d = 0; d < unsigned(dim); ++d)
      if (points[k].components[d]) {
        c.rows.push_back(constraint_row<dim>(m, points[k], d, 0.0, k, true));
        c.point.push_back(k), c.comp.push_back(d);
      }
    c.first_row.push_back(c.rows.size());
  }
  for (std::size_t p = 0; p < probes.size(); ++p)
    for (unsigned d = 0; d < unsigned(dim); ++d)
      c.probe_rows.push_back(constraint_row<dim>(m, PointConstraint<dim>(probes[p]), d, 0.0, p, true));
  c.probe_u.assign(probes.size(), Vec<dim>::Zero());
  c.U.reinit(m.dof.n_dofs());
  c.mu_all.assign(c.rows.size(), 0.0);
  c.column_of.assign(c.rows.size(), -1);
  c.stats.method = "newton+cholmod";
  c.stats.n_dofs = m.dof.n_dofs();
}

template <int dim>
FiniteStrainRows<dim>::~FiniteStrainRows() = default;
template <int dim>
FiniteStrainRows<dim>::FiniteStrainRows(FiniteStrainRows&&) noexcept = default;

template <int dim>
std::size_t FiniteStrainRows<dim>::n_points() const {
  return impl_->first_row.size() - 1;
}

// Continuation from the last state (load factor t₀, the rows' values h₀ = C U − κ μ) to the full loads
// and the new values g: at s ∈ (0, 1] the loads t₀ + s(1 − t₀), the rows h₀ + s(g − h₀), the rows left
// out with (1 − s) of their multipliers; s = 0 is the last state itself, an equilibrium.
template <int dim>
void FiniteStrainRows<dim>::solve(const std::vector<std::size_t>& active,
                                  const std::vector<Vec<dim>>& displacement) {
  Impl& c = *impl_;
  if (displacement.size() < active.size())
    throw std::invalid_argument("FiniteStrainRows::solve: one displacement per active point");
  std::vector<std::size_t> used, slot;
  std::vector<double> g, h0, mu0;
  std::vector<bool> in(c.rows.size(), false);
  for (std::size_t i = 0; i < active.size(); ++i) {
    if (active[i] >= n_points()) throw std::invalid_argument("FiniteStrainRows: point index out of range");
    for (std::size_t a = c.first_row[active[i]]; a < c.first_row[active[i] + 1]; ++a) {
      if (!c.rows[a].active) continue;
      used.push_back(a), slot.push_back(i), in[a] = true;
      g.push_back(displacement[i][c.comp[a]]);
      mu0.push_back(c.mu_all[a]);
      h0.push_back(row_value(c.rows[a], c.U, c.t) - c.rows[a].compliance * c.mu_all[a]);
    }
  }
  std::vector<std::pair<std::size_t, double>> dead0;
  for (std::size_t a = 0; a < c.rows.size(); ++a)
    if (!in[a] && c.mu_all[a] != 0.0) dead0.emplace_back(a, c.mu_all[a]);
  c.used = used, c.used_slot = slot, c.n_active = active.size();
  c.steps.clear();
  c.halvings = 0;
  const double t0 = c.t;
  double s = 0.0, ds = 1.0;
  unsigned in_row = 0;
  std::vector<double> gt(g.size());
  while (s < 1.0) {
    const double s_next = (1.0 - s) <= ds * (1.0 + 1e-12) ? 1.0 : s + ds;
    const Vector<double> saved = c.U;
    const std::vector<double> saved_mu = c.mu;
    c.mu = c.steps.empty() && s == 0.0 ? mu0 : c.mu;
    for (std::size_t a = 0; a < g.size(); ++a) gt[a] = h0[a] + s_next * (g[a] - h0[a]);
    auto dead = dead0;
    for (auto& d : dead) d.second *= 1.0 - s_next;
    LoadStepRecord rec;
    rec.load_factor = s_next;
    if (c.newton(t0 + s_next * (1.0 - t0), gt, dead, rec)) {
      c.stats.iterations += static_cast<unsigned>(rec.update_norm.size());
      c.steps.push_back(std::move(rec));
      s = s_next;
      in_row = 0;
      ds = std::min(2.0 * ds, 1.0);
      continue;
    }
    c.U = saved;
    c.mu = s == 0.0 ? mu0 : saved_mu;
    c.factor.reset();  // the failed iterate's tangent
    c.factor_at_U = false;
    if (++in_row > c.opt.max_halvings) {
      std::ostringstream msg;
      msg << "neo-Hookean solve with " << g.size() << " point-constraint rows: the step from " << s << " to "
          << s_next << " of the way to the new row values did not converge after " << c.opt.max_halvings
          << " halvings (Newton: " << c.opt.max_iterations << " iterations, tolerance " << c.opt.tolerance
          << ")";
      throw NewtonFailure(msg.str());
    }
    ++c.halvings;
    ds *= 0.5;
  }
  c.t = 1.0;
  std::fill(c.mu_all.begin(), c.mu_all.end(), 0.0);
  for (std::size_t a = 0; a < used.size(); ++a) c.mu_all[used[a]] = c.mu[a];
  for (std::size_t p = 0; p < c.probe_u.size(); ++p)
    for (int d = 0; d < dim; ++d) c.probe_u[p][d] = row_value(c.probe_rows[p * dim + d], c.U, c.t);
  c.have_tangent = false;
  c.stats.constraint_rows = static_cast<unsigned>(used.size());
}

template <int dim>
void FiniteStrainRows<dim>::point_forces(std::vector<Vec<dim>>& force) const {
  const Impl& c = *impl_;
  force.assign(c.n_active, Vec<dim>::Zero());
  for (std::size_t a = 0; a < c.used.size(); ++a)
    force[c.used_slot[a]] -= c.mu[a] * c.axes[c.point[c.used[a]]].col(c.comp[c.used[a]]);
}

template <int dim>
const std::vector<Vec<dim>>& FiniteStrainRows<dim>::probe_displacements() const {
  return impl_->probe_u;
}

template <int dim>
Vec<dim> FiniteStrainRows<dim>::held_displacement(std::size_t k) const {
  const Impl& c = *impl_;
  Vec<dim> u = Vec<dim>::Zero();
  for (std::size_t a = c.first_row[k]; a < c.first_row[k + 1]; ++a)
    u += row_value(c.rows[a], c.U, c.t) * c.axes[k].col(c.comp[a]);
  return u;
}

template <int dim>
const std::vector<LoadStepRecord>& FiniteStrainRows<dim>::steps() const {
  return impl_->steps;
}
template <int dim>
unsigned FiniteStrainRows<dim>::halvings() const {
  return impl_->halvings;
}
template <int dim>
const SolverStats& FiniteStrainRows<dim>::stats() const {
  return impl_->stats;
}

template <int dim>
void FiniteStrainRows<dim>::linearised_forces(const std::vector<Vec<dim>>& dg, std::vector<Vec<dim>>& df) {
  Impl& c = *impl_;
  if (!c.have_tangent) {
    Vector<double> rhs;
    if (!c.factor_at_U) {
      if (!c.refactor(c.U, c.t, Vector<double>(c.U.size()), rhs))
        throw std::runtime_error("FiniteStrainRows: no positive definite tangent at the state");
      c.factor_at_U = true;
    }
    c.tangent.factor(c.schur());
    c.have_tangent = true;
  }
  Eigen::VectorXd b(static_cast<Eigen::Index>(c.used.size()));
  for (std::size_t a = 0; a < c.used.size(); ++a)
    b[static_cast<Eigen::Index>(a)] = dg[c.used_slot[a]][c.comp[c.used[a]]];
  const Eigen::VectorXd x = c.tangent.solve(b);  // −Δμ
  df.assign(c.n_active, Vec<dim>::Zero());
  for (std::size_t a = 0; a < c.used.size(); ++a)
    df[c.used_slot[a]] += x[static_cast<Eigen::Index>(a)] * c.axes[c.point[c.used[a]]].col(c.comp[c.used[a]]);
}

template <int dim>
Solution<dim> FiniteStrainRows<dim>::field() {
  Impl& c = *impl_;
  State<dim>& m = *c.m;
  m.u = c.U;
  m.have_solution = true;
  m.grid_vertex_u.clear();
  Solution<dim> s = m.postprocess();
  finite_strain_fields<dim>(m, c.sys->law(), c.U, c.t, s);
  for (std::size_t a = 0; a < c.used.size(); ++a)
    add_constraint_reactions<dim>(c.rows[c.used[a]], c.mu[a], s);
  point_forces(s.point_force);
  s.stats = c.stats;
  return s;
}

#define VIM_FEM_FINITE_STRAIN(dim)                                                                       \
  template FiniteStrainSolution<dim> solve_neo_hookean(ElasticModel<dim>&, const NewtonOptions&);        \
  template void neo_hookean_system(ElasticModel<dim>&, const Eigen::VectorXd&, double, Eigen::VectorXd&, \
                                   Eigen::MatrixXd&);
VIM_FEM_FINITE_STRAIN(2)
VIM_FEM_FINITE_STRAIN(3)
template class FiniteStrainRows<2>;
template class FiniteStrainRows<3>;

}  // namespace vim::fem

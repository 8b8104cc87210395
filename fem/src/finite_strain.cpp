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

#include "model_state.hpp"
#include "neo_hookean_material.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

template <int dim>
using State = ModelAccess::State<dim>;

// One constrained DoF of the model: u_i = t · inhomogeneity + Σ a_f u_f.
struct Line {
  types::global_dof_index dof;
  double inhomogeneity;
  std::vector<std::pair<types::global_dof_index, double>> entries;
};

template <int dim>
class NewtonSystem {
 public:
  explicit NewtonSystem(State<dim>& m) : m_(m), law_(m.E, m.nu) {
    const unsigned n = m.dof.n_dofs();
    for (types::global_dof_index i = 0; i < n; ++i) {
      if (!m.constraints.is_constrained(i)) continue;
      Line l{i, m.constraints.get_inhomogeneity(i), {}};
      if (const auto* e = m.constraints.get_constraint_entries(i)) l.entries = *e;
      homogeneous_.add_line(i);
      homogeneous_.add_entries(i, l.entries);
      lines_.push_back(std::move(l));
    }
    homogeneous_.close();
    DynamicSparsityPattern dsp(n, n);
    DoFTools::make_sparsity_pattern(m.dof, dsp);
    homogeneous_.condense(dsp);
    sparsity_.copy_from(dsp);
  }

  const NeoHookeanMaterial<dim>& law() const { return law_; }

  // r(U) of every DoF and, if K is given, the tangent (unconstrained, supports in). False if some
  // quadrature point has J ≤ 0 (r and K are then incomplete).
  bool assemble(const Vector<double>& U, double t, Vector<double>& r, SparseMatrix<double>* K) const {
    const unsigned dpc = m_.fe->n_dofs_per_cell();
    auto fv = m_.make_fe_values();
    r.reinit(U.size());
    if (K) K->reinit(sparsity_);
    if (K && !m_.K_support.empty()) {
      for (unsigned i = 0; i < m_.K_support.m(); ++i)
        for (auto it = m_.K_support.begin(i); it != m_.K_support.end(i); ++it)
          K->add(i, it->column(), it->value());
    }
    FullMatrix<double> Ke(dpc, dpc);
    Vector<double> Re(dpc);
    std::vector<types::global_dof_index> idx(dpc);
    std::vector<Tensor<1, dim>> grad(dpc);
    std::vector<unsigned> comp(dpc);
    for (unsigned i = 0; i < dpc; ++i) comp[i] = m_.fe->system_to_component_index(i).first;
    for (const auto& cell : m_.dof.active_cell_iterators()) {
      fv->reinit(cell);
      cell->get_dof_indices(idx);
      const unsigned j = cell->material_id();
      Ke = 0.0;
      Re = 0.0;
      for (unsigned q = 0; q < fv->n_quadrature_points; ++q) {
        Tensor<2, dim> H;
        for (unsigned i = 0; i < dpc; ++i) {
          grad[i] = fv->shape_grad(i, q);
          H[comp[i]] += U[idx[i]] * grad[i];
        }
        if (!(determinant(unit_symmetric_plus(H)) > 0.0)) return false;
        const double w = fv->JxW(q);
        const Tensor<2, dim> P = law_.stress(j, H);
        for (unsigned i = 0; i < dpc; ++i) Re(i) += (P[comp[i]] * grad[i]) * w;
        if (!K) continue;
        // Ke_ik += Σ_JL ∂_J N_i A_{c_i J c_k L} ∂_L N_k
        const Tensor<4, dim> A = law_.tangent(j, H);
        for (unsigned i = 0; i < dpc; ++i) {
          Tensor<2, dim> T;  // T_kL = Σ_J ∂_J N_i A_{c_i J k L}
          for (unsigned J = 0; J < dim; ++J) T += grad[i][J] * A[comp[i]][J];
          for (unsigned k = 0; k < dpc; ++k) Ke(i, k) += (T[comp[k]] * grad[k]) * w;
        }
      }
      r.add(idx, Re);
      if (K) K->add(idx, Ke);
    }
    r.add(-t, m_.f_full);
    if (!m_.K_support.empty()) m_.K_support.vmult_add(r, U);
    return true;
  }

  // ‖r‖ over the free DoFs: r with the conditions eliminated.
  double free_norm(const Vector<double>& r) const {
    Vector<double> c(r);
    homogeneous_.condense(c);
    return c.l2_norm();
  }

  // g_i = t · inhomogeneity + Σ a u_f − u_i on the constrained DoFs (0 elsewhere): what an update
  // must add there for U to satisfy the conditions at load factor t.
  Vector<double> condition_gap(const Vector<double>& U, double t) const {
    Vector<double> g(U.size());
    for (const Line& l : lines_) g[l.dof] = target(l, U, t) - U[l.dof];
    return g;
  }
  // Sets the constrained DoFs of U to their values at load factor t (exactly: condition_gap is 0).
  void impose(Vector<double>& U, double t) const {
    for (const Line& l : lines_) U[l.dof] = target(l, U, t);
  }

  // The Newton update du: K du = −r with du = g on the conditions' DoFs (g from condition_gap), K and
  // r as assembled (K is condensed in place). Throws std::runtime_error if K is not positive definite.
  Vector<double> update(SparseMatrix<double>& K, const Vector<double>& r, const Vector<double>& g,
                        double* rhs_norm) const {
    Vector<double> rhs(r.size());
    K.vmult(rhs, g);
    rhs += r;
    rhs *= -1.0;
    homogeneous_.condense(K, rhs);
    // the conditions' rows and columns: a unit-scaled diagonal, nothing else
    double diag = 0.0;
    for (unsigned i = 0; i < K.m(); ++i) diag = std::max(diag, std::abs(K.diag_element(i)));
    for (unsigned i = 0; i < K.m(); ++i)
      for (auto it = K.begin(i); it != K.end(i); ++it)
        if (homogeneous_.is_constrained(i) || homogeneous_.is_constrained(it->column())) it->value() = 0.0;
    for (const Line& l : lines_) {
      K.set(l.dof, l.dof, diag > 0.0 ? diag : 1.0);
      rhs[l.dof] = 0.0;
    }
    *rhs_norm = rhs.l2_norm();
    const auto factor = cholmod_factor(K);
    factor->solve(rhs.data());
    homogeneous_.distribute(rhs);
    rhs += g;
    return rhs;
  }

 private:
  static double target(const Line& l, const Vector<double>& U, double t) {
    double v = t * l.inhomogeneity;
    for (const auto& [f, a] : l.entries) v += a * U[f];
    return v;
  }
  static Tensor<2, dim> unit_symmetric_plus(const Tensor<2, dim>& H) {
    return Physics::Elasticity::Kinematics::F(H);
  }
  State<dim>& m_;
  NeoHookeanMaterial<dim> law_;
  std::vector<Line> lines_;
  AffineConstraints<double> homogeneous_;
  SparsityPattern sparsity_;
};

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

#define VIM_FEM_FINITE_STRAIN(dim)                                                                       \
  template FiniteStrainSolution<dim> solve_neo_hookean(ElasticModel<dim>&, const NewtonOptions&);        \
  template void neo_hookean_system(ElasticModel<dim>&, const Eigen::VectorXd&, double, Eigen::VectorXd&, \
                                   Eigen::MatrixXd&);
VIM_FEM_FINITE_STRAIN(2)
VIM_FEM_FINITE_STRAIN(3)

}  // namespace vim::fem

// Internal to vim_fem (deal.II inside): the residual and tangent of the neo-Hookean model at a DoF
// vector and load factor, and the Newton update with the Dirichlet conditions eliminated — shared by the
// static solve (solve_neo_hookean) and the rows' solve (FiniteStrainRows), finite_strain.cpp.
#pragma once

#include <deal.II/dofs/dof_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "model_state.hpp"
#include "neo_hookean_material.hpp"

namespace vim::fem {

using namespace dealii;

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
    Vector<double> rhs;
    const auto factor = factorise(K, r, g, rhs);
    *rhs_norm = rhs.l2_norm();
    factor->solve(rhs.data());
    homogeneous_.distribute(rhs);
    rhs += g;
    return rhs;
  }

  // K condensed in place (the conditions' rows and columns: a unit-scaled diagonal) and factorised, with
  // the condensed right-hand side −(r + K g) of the update. Throws std::runtime_error if K is not
  // positive definite.
  std::unique_ptr<CholmodLLT> factorise(SparseMatrix<double>& K, const Vector<double>& r,
                                        const Vector<double>& g, Vector<double>& rhs) const {
    rhs.reinit(r.size());
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
    return cholmod_factor(K);
  }
  void condense(Vector<double>& v) const { homogeneous_.condense(v); }
  void distribute(Vector<double>& v) const { homogeneous_.distribute(v); }

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

}  // namespace vim::fem

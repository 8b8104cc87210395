// Internal to vim_fem (deal.II inside): the residual and tangent of the neo-Hookean model at a DoF
// vector and load factor, and the Newton update with the Dirichlet conditions eliminated — shared by the
// static solve (solve_neo_hookean) and the rows' solve (FiniteStrainRows), finite_strain.cpp.
#pragma once

#include <deal.II/dofs/dof_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <utility>
#include <vector>

#include "cholmod_llt.hpp"
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
    store_geometry();
  }

  const NeoHookeanMaterial<dim>& law() const { return law_; }

  // r(U) of every DoF and, if K is given, the tangent (unconstrained, supports in). False if some
  // quadrature point has J ≤ 0 (r and K are then incomplete).
  bool assemble(const Vector<double>& U, double t, Vector<double>& r, SparseMatrix<double>* K) const {
    const unsigned dpc = geometry_.dofs_per_cell, nq = geometry_.n_q_points;
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
    const std::vector<unsigned>& comp = geometry_.component;
    for (std::size_t c = 0; c < geometry_.material.size(); ++c) {
      std::copy_n(geometry_.dofs.begin() + static_cast<std::ptrdiff_t>(c * dpc), dpc, idx.begin());
      const unsigned j = geometry_.material[c];
      Ke = 0.0;
      Re = 0.0;
      for (unsigned q = 0; q < nq; ++q) {
        const Tensor<1, dim>* grad = geometry_.grad.data() + (c * nq + q) * dpc;
        Tensor<2, dim> H;
        for (unsigned i = 0; i < dpc; ++i) H[comp[i]] += U[idx[i]] * grad[i];
        if (!(determinant(unit_symmetric_plus(H)) > 0.0)) return false;
        const double w = geometry_.JxW[c * nq + q];
        const Tensor<2, dim> P = law_.stress(j, H);
        for (unsigned i = 0; i < dpc; ++i) Re(i) += (P[comp[i]] * grad[i]) * w;
        if (!K) continue;
        // Ke_ik += Σ_JL ∂_J N_i A_{c_i J c_k L} ∂_L N_k, for k ≥ i (A has the major symmetry)
        const Tensor<4, dim> A = law_.tangent(j, H);
        for (unsigned i = 0; i < dpc; ++i) {
          Tensor<2, dim> T;  // T_kL = Σ_J ∂_J N_i A_{c_i J k L}
          for (unsigned J = 0; J < dim; ++J) T += grad[i][J] * A[comp[i]][J];
          for (unsigned k = i; k < dpc; ++k) Ke(i, k) += (T[comp[k]] * grad[k]) * w;
        }
      }
      r.add(idx, Re);
      if (K) add_symmetric(c, Ke, *K);
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
    return cholmod(K);
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
  // The cells' reference geometry, fixed in the total Lagrangian form: per cell its DoFs and material,
  // per quadrature point JxW and the shape gradients, from FEValues once (the values FEValues gives
  // on every reinit).
  struct Geometry {
    unsigned dofs_per_cell = 0, n_q_points = 0;
    std::vector<unsigned> component, material;  // per cell DoF; per cell
    std::vector<types::global_dof_index> dofs;  // cell × DoF
    std::vector<unsigned> ascending;            // cell × DoF: the cell's DoFs in ascending order
    std::vector<double> JxW;                    // cell × point
    std::vector<Tensor<1, dim>> grad;           // cell × point × DoF
  };
  void store_geometry() {
    Geometry& g = geometry_;
    auto fv = m_.make_fe_values();
    g.dofs_per_cell = m_.fe->n_dofs_per_cell();
    g.n_q_points = fv->n_quadrature_points;
    for (unsigned i = 0; i < g.dofs_per_cell; ++i)
      g.component.push_back(m_.fe->system_to_component_index(i).first);
    std::vector<types::global_dof_index> idx(g.dofs_per_cell);
    for (const auto& cell : m_.dof.active_cell_iterators()) {
      fv->reinit(cell);
      cell->get_dof_indices(idx);
      g.dofs.insert(g.dofs.end(), idx.begin(), idx.end());
      std::vector<unsigned> order(g.dofs_per_cell);
      std::iota(order.begin(), order.end(), 0u);
      std::sort(order.begin(), order.end(), [&](unsigned a, unsigned b) { return idx[a] < idx[b]; });
      g.ascending.insert(g.ascending.end(), order.begin(), order.end());
      g.material.push_back(cell->material_id());
      for (unsigned q = 0; q < g.n_q_points; ++q) {
        g.JxW.push_back(fv->JxW(q));
        for (unsigned i = 0; i < g.dofs_per_cell; ++i) g.grad.push_back(fv->shape_grad(i, q));
      }
    }
  }
  // K += Ke of cell c (its upper triangle given, mirrored), row by row with the cell's DoFs in
  // ascending order (deal.II's merge of sorted columns into the row).
  void add_symmetric(std::size_t c, const FullMatrix<double>& Ke, SparseMatrix<double>& K) const {
    const unsigned dpc = geometry_.dofs_per_cell;
    const unsigned* order = geometry_.ascending.data() + c * dpc;
    const types::global_dof_index* dofs = geometry_.dofs.data() + c * dpc;
    std::vector<types::global_dof_index> cols(dpc);
    std::vector<double> row(dpc);
    for (unsigned k = 0; k < dpc; ++k) cols[k] = dofs[order[k]];
    for (unsigned i = 0; i < dpc; ++i) {
      for (unsigned k = 0; k < dpc; ++k) {
        const unsigned b = order[k];
        row[k] = b >= i ? Ke(i, b) : Ke(b, i);
      }
      K.add(dofs[i], dpc, cols.data(), row.data(), false, true);
    }
  }
  // The CHOLMOD factor of the condensed K: the pattern (sparsity_'s upper triangle, fixed) analysed on
  // the first call, K's values gathered into it on each.
  std::unique_ptr<CholmodLLT> cholmod(const SparseMatrix<double>& K) const {
    if (!analysis_) analyse(K);
    std::vector<double> Ax(analysis_->n_entries());
    std::size_t e = 0;
    for (unsigned i = 0; i < K.m(); ++i)
      for (auto it = K.begin(i); it != K.end(i); ++it, ++e)
        if (upper_slot_[e] >= 0) Ax[static_cast<std::size_t>(upper_slot_[e])] = it->value();
    return std::make_unique<CholmodLLT>(*analysis_, Ax);
  }
  // Column i of the upper triangle: row i's entries with column ≤ i, sorted (K is symmetric); each of
  // K's entries, in the order its rows are iterated, gets its slot there (−1 below the diagonal).
  void analyse(const SparseMatrix<double>& K) const {
    const auto n = static_cast<long>(K.m());
    std::vector<long> Ap(static_cast<std::size_t>(n) + 1, 0), Ai;
    std::vector<std::pair<long, std::size_t>> column;  // (row in the triangle, entry of K)
    upper_slot_.clear();
    for (long i = 0; i < n; ++i) {
      column.clear();
      for (auto it = K.begin(static_cast<unsigned>(i)); it != K.end(static_cast<unsigned>(i)); ++it) {
        if (static_cast<long>(it->column()) <= i)
          column.emplace_back(static_cast<long>(it->column()), upper_slot_.size());
        upper_slot_.push_back(-1);
      }
      std::sort(column.begin(), column.end());
      for (const auto& [row, entry] : column) {
        upper_slot_[entry] = static_cast<long>(Ai.size());
        Ai.push_back(row);
      }
      Ap[static_cast<std::size_t>(i) + 1] = static_cast<long>(Ai.size());
    }
    analysis_ = std::make_unique<CholmodAnalysis>(n, std::move(Ap), std::move(Ai));
  }

  State<dim>& m_;
  NeoHookeanMaterial<dim> law_;
  Geometry geometry_;
  mutable std::unique_ptr<CholmodAnalysis> analysis_;
  mutable std::vector<long> upper_slot_;
  std::vector<Line> lines_;
  AffineConstraints<double> homogeneous_;
  SparsityPattern sparsity_;
};

}  // namespace vim::fem

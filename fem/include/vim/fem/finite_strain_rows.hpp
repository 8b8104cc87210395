// Embedded point constraints (a needle's coupling rows, PointConstraint: averaged samples, axes,
// compliances in series) on the neo-Hookean model of finite_strain.hpp. Each solve is one Newton
// solve of
//   r(U) + Cᵀμ = 0,   C U − κ μ = g       (r the residual of finite_strain.hpp, μ the rows' multipliers:
//                                          the force on the body along a row's axis is −μ)
// from the state of the previous solve (the model's loads first brought to their full value by
// adaptive load steps), continued from the rows' previous values to the new ones and halved when it
// fails (docs/finite-strain.md, "Needle insertion"). Each Newton iteration factorises the tangent K
// with CHOLMOD and condenses the rows on it: S = C K⁻¹ Cᵀ + diag(κ), Δμ = S⁻¹(C K⁻¹ r₁ + r₂). The
// linearised forces at the converged state (the condensed compliance of the tangent) give a needle's
// friction active set its axial map. Serial models only. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>
#include <vim/fem/finite_strain.hpp>
#include <vim/fem/model.hpp>

namespace vim::fem {

template <int dim>
class FiniteStrainRows {
 public:
  // `points`: the constraints (their displacements are ignored: solve() gives them); `probes`: points
  // whose displacement each solve evaluates. Throws std::invalid_argument for a point or probe outside
  // the mesh, or a model whose solves run over MPI ranks.
  FiniteStrainRows(ElasticModel<dim>& model, const std::vector<PointConstraint<dim>>& points,
                   const std::vector<Vec<dim>>& probes, const NewtonOptions& options = {});
  ~FiniteStrainRows();
  FiniteStrainRows(FiniteStrainRows&&) noexcept;

  std::size_t n_points() const;

  // Holds the points `active` (indices into the constructor's list) at `displacement[i]` (in the
  // point's axes) and solves by Newton from the last solve's state. Throws NewtonFailure (the
  // continuation halved max_halvings times in a row without converging).
  void solve(const std::vector<std::size_t>& active, const std::vector<Vec<dim>>& displacement);
  // Of the last solve: the force on the body per active point (model axes; order of `active`),
  void point_forces(std::vector<Vec<dim>>& force) const;
  // the displacement at each probe,
  const std::vector<Vec<dim>>& probe_displacements() const;
  // the displacement a point's rows hold (the mean along its selected axes, model axes), any point,
  Vec<dim> held_displacement(std::size_t point) const;
  // the continuation steps of the last solve (load_factor: the fraction of the way from the previous
  // rows' values to the new ones, 1 at the end) with their Newton residual norms,
  const std::vector<LoadStepRecord>& steps() const;
  unsigned halvings() const;  // of the last solve
  // and the tangent: the change of the active points' forces (model axes) for a change of their held
  // displacements (point axes) at the last solve's state, −Cᵀ Δμ with Δμ = −S⁻¹ Δg and S = C K⁻¹ Cᵀ +
  // diag(κ), K the tangent at that state (assembled and factorised once per solve, on first use).
  void linearised_forces(const std::vector<Vec<dim>>& d_displacement, std::vector<Vec<dim>>& d_force);
  // The whole solution of the last solve (vertex displacements, Green–Lagrange strain, Cauchy stress,
  // energy, reactions, point forces); it becomes the model's last solution, for sample().
  Solution<dim> field();
  const SolverStats& stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::fem

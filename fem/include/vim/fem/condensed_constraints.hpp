// A fixed set of embedded point constraints of an ElasticModel, condensed once (docs/performance.md,
// "Needle steps"): the columns K⁻¹cᵀ of every row, their products G_ab = c_a K⁻¹c_bᵀ, c·u0 and the
// values of every column at chosen probe points are computed at construction (one factorisation,
// blocks of right-hand sides). A solve with any subset of the points held at any displacements is then
// dense work on the active rows alone:
//   S = G[act, act] + diag(κ),  μ = S⁻¹(C u0 − g),  forces −Cᵀμ per point,
//   probe displacements u(p) = N_p·u0 − Σ_a μ_a N_p·K⁻¹c_aᵀ,
// the same rows, dropping rule and errors as ElasticModel::solve(points). The whole field
// (u = u0 − K⁻¹Cᵀμ, strains, stresses, energy, reactions) is formed only on request (field()), equal to
// ElasticModel::solve with the same points. Rows are identified by their index in the constructor's
// list: nothing is looked up or copied per solve, and after the first solve of the largest active set
// solve() allocates nothing. The object refers to the model: adding a condition to the model
// invalidates it. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>
#include <vim/fem/model.hpp>

namespace vim::fem {

template <int dim>
class CondensedConstraints {
 public:
  // `points`: the constraints (position, samples, axes, selected components, compliance; their
  // displacements are ignored); `probes`: points (inside the mesh) whose displacement solve() returns.
  // Factorises K if needed. Same errors as ElasticModel::precompute, std::invalid_argument for a probe
  // outside the mesh.
  CondensedConstraints(ElasticModel<dim>& model, const std::vector<PointConstraint<dim>>& points,
                       const std::vector<Vec<dim>>& probes, const SolverOptions& options = {});
  ~CondensedConstraints();
  CondensedConstraints(CondensedConstraints&&) noexcept;

  std::size_t n_points() const;
  std::size_t n_rows() const;  // selected components of all points

  // Holds the points `active` (indices into the constructor's list, each at most once) at
  // `displacement[i]` (components in the point's axes, as PointConstraint::displacement) and solves.
  // Throws DependentPointConstraints / std::invalid_argument as ElasticModel::solve does.
  void solve(const std::vector<std::size_t>& active, const std::vector<Vec<dim>>& displacement);
  // Of the last solve: the force on the body per active point (model axes; order of `active`),
  void point_forces(std::vector<Vec<dim>>& force) const;
  // the displacement at each probe (model axes),
  const std::vector<Vec<dim>>& probe_displacements() const;
  // the displacement a point's rows hold (the point's, or its samples' mean) along its selected axes,
  // model axes, for any point of the list, active or not,
  Vec<dim> held_displacement(std::size_t point) const;
  // and the statistics (method, rows used and dropped; no iterations: no sparse solve).
  const SolverStats& stats() const;
  // The whole solution of the last solve, equal to ElasticModel::solve with the same points (it
  // becomes the model's last solution, for ElasticModel::sample).
  Solution<dim> field();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::fem

// The neo-Hookean model behind the tissue interface (docs/finite-strain.md, "Needle insertion"): each
// solve holds the active points' rows at their values by one Newton solve of the finite-strain model
// from the previous solve's state (fem::FiniteStrainRows); the axial map is the tangent at the last
// solve's state (the condensed compliance of the rows on the tangent stiffness), so the laws repeat
// map and solve until the forces agree (TissueResponse::nonlinear). The band's compliances in series
// (the analytic near field of the shaft inside the band) stay linear.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>
#include <vim/fem/finite_strain_rows.hpp>
#include <vim/needle/coupling.hpp>
#include <vim/needle/model_tissue.hpp>

namespace vim::needle {

// The Newton record of one tissue solve: its continuation steps (fem::LoadStepRecord) and halvings.
struct NewtonSolveRecord {
  std::vector<fem::LoadStepRecord> steps;
  unsigned halvings = 0;
};

template <int dim>
class NeoHookeanTissue final : public ModelTissue<dim> {
 public:
  NeoHookeanTissue(fem::ElasticModel<dim>& model, const NeedleCoupling<dim>& coupling,
                   const ShaftState& state, std::size_t n_points, const fem::NewtonOptions& newton = {});
  ~NeoHookeanTissue() override;

  void precompute(const std::vector<Vec<dim>>& probes) override;
  // Throws fem::NewtonFailure when the Newton solve does not converge.
  const std::vector<double>& solve(const std::vector<double>& axial) override;
  // The tangent at the last solve (first a solve of the current values when the active points changed).
  const AxialMap& axial_map() override;
  bool nonlinear() const override { return true; }

  void form_field() override;
  void clear() override;
  fem::Solution<dim>& solution() override { return solution_; }
  double held_axial(std::size_t j, const Vec<dim>& axis) const override;
  std::vector<Vec<dim>> probe_displacements(const std::vector<Vec<dim>>& probes) const override;
  int solves() const override { return solves_; }
  double solve_seconds() const override { return solve_seconds_; }
  // The Newton records of the solves since the last call (a step's), and forgets them.
  std::vector<NewtonSolveRecord> take_records();

 private:
  fem::ElasticModel<dim>& model_;
  const NeedleCoupling<dim>& coupling_;
  const ShaftState& state_;
  std::size_t n_points_;
  fem::NewtonOptions newton_;
  std::unique_ptr<fem::FiniteStrainRows<dim>> rows_;
  std::vector<Vec<dim>> held_, d_held_, d_force_;
  std::vector<double> forces_, axial_;  // of the last solve
  std::vector<std::size_t> solved_active_;
  bool loaded_rows_ = false;  // the last solve held some rows
  fem::Solution<dim> solution_;
  bool field_ = false;
  AxialMap map_;
  bool map_current_ = false;
  std::vector<NewtonSolveRecord> records_;
  int solves_ = 0;
  double solve_seconds_ = 0.0;
};

}  // namespace vim::needle

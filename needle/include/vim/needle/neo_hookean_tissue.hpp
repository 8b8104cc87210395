// The neo-Hookean model behind the tissue interface (docs/finite-strain.md, "Needle insertion"): each
// solve holds the active points' rows at their values by one Newton solve of the finite-strain model
// from the previous solve's state (fem::FiniteStrainRows); the axial map is the tangent at the last
// solve's state (the condensed compliance of the rows on the tangent stiffness), or the last map's
// stiffness kept while it predicts the solves' forces (kept_map_miss_ratio), so the laws repeat map
// and solve until the forces agree (TissueResponse::nonlinear). The band's compliances in series
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

// The axial map's stiffness is kept between solves with the same active points (a chord map: only its
// offset is renewed at each solve) while its prediction of each solve's forces misses by at most this
// fraction of their change since the map was renewed; the laws' rounds then contract the force misfit
// by about this factor each, to the same tolerance (kNonlinearForceTolerance) as with a fresh tangent
// per map. 0: a fresh tangent for every map (the tests compare both).
inline double kept_map_miss_ratio = 0.1;

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

  void clear() override;
  double held_axial(std::size_t j, const Vec<dim>& axis) const override;
  std::vector<Vec<dim>> probe_displacements(const std::vector<Vec<dim>>& probes) const override;
  // The Newton records of the solves since the last call (a step's), and forgets them.
  std::vector<NewtonSolveRecord> take_records();

 private:
  using Base = ModelTissue<dim>;
  using Base::coupling_, Base::field_, Base::map_, Base::model_, Base::n_points_, Base::solution_,
      Base::solve_seconds_, Base::state_;
  fem::Solution<dim> whole_field() override;
  bool keep_map() const;

  fem::NewtonOptions newton_;
  std::unique_ptr<fem::FiniteStrainRows<dim>> rows_;
  std::vector<Vec<dim>> held_, d_held_, d_force_;
  std::vector<double> forces_, axial_;  // of the last solve
  std::vector<std::size_t> solved_active_;
  bool loaded_rows_ = false;  // the last solve held some rows
  bool map_current_ = false;
  std::vector<std::size_t> map_active_;  // the active points of the map's K (empty: none)
  Eigen::VectorXd map_base_;             // the forces where the map was last renewed
  std::vector<NewtonSolveRecord> records_;
};

}  // namespace vim::needle

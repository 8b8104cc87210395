// The linear elastic model behind the tissue interface (TissueResponse): the coupling rows of every
// shaft point (and the probe points) condensed once (fem::CondensedConstraints), so that a solve of
// the active points' axial values is the dense Schur system of their rows; the whole field only on
// request. The monolithic saddle-point solve of the same rows is the reference.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>
#include <vim/fem/condensed_constraints.hpp>
#include <vim/fem/model.hpp>
#include <vim/needle/coupling.hpp>
#include <vim/needle/model_tissue.hpp>

namespace vim::needle {

template <int dim>
class ElasticTissue final : public ModelTissue<dim> {
 public:
  // `state` is the stepping's (its active points are the rows of each solve); `probe_step`: the axial
  // value of the axial map's probes (the shaft pitch). monolithic: every solve with solve_monolithic.
  ElasticTissue(fem::ElasticModel<dim>& model, const NeedleCoupling<dim>& coupling, const ShaftState& state,
                std::size_t n_points, double probe_step, const fem::SolverOptions& solver, bool monolithic);
  ~ElasticTissue() override;

  // Before precompute: rows held at their displacements in every solve (the stations of needles left in
  // the tissue, as their last step left them). Their forces are not the needle's: solution().point_force
  // has the shaft's rows alone, the field has all.
  void hold(std::vector<fem::PointConstraint<dim>> rows) { held_rows_ = std::move(rows); }
  bool holds() const { return !held_rows_.empty(); }
  // The force on the body of each held row in the last solve (model axes; hold()'s order).
  const std::vector<Vec<dim>>& held_forces() const { return held_forces_; }

  // Before stepping: the rows of every shaft point (and the held rows) and the probes, and their
  // columns K⁻¹cᵀ in one batch, so that no step does a sparse solve (nothing with the monolithic
  // reference).
  void precompute(const std::vector<Vec<dim>>& probes) override;

  const std::vector<double>& solve(const std::vector<double>& axial) override;
  const AxialMap& axial_map() override;

  // No contact: an empty solution that counts as formed.
  void clear() override;
  // The displacement along `axis` that point j's rows hold in the last solution.
  double held_axial(std::size_t j, const Vec<dim>& axis) const override;
  // The probes' displacements in the last solve (the model's samples with the monolithic reference).
  std::vector<Vec<dim>> probe_displacements(const std::vector<Vec<dim>>& probes) const override;

 private:
  using Base = ModelTissue<dim>;
  using Base::coupling_, Base::field_, Base::map_, Base::model_, Base::n_points_, Base::solution_,
      Base::state_;
  // The condensed rows' field (the monolithic solve formed it in solve()).
  fem::Solution<dim> whole_field() override;

  double probe_step_;
  fem::SolverOptions solver_;
  bool monolithic_;
  std::unique_ptr<fem::CondensedConstraints<dim>> condensed_;
  std::vector<fem::PointConstraint<dim>> held_rows_;  // hold(): after the shaft's rows
  std::vector<std::size_t> active_;                   // the active shaft rows, then the held rows
  std::vector<Vec<dim>> held_forces_;                 // of the held rows in the last solve
  std::vector<Vec<dim>> held_;                        // the active rows' displacements of a solve
  std::vector<double> forces_;                        // the axial forces of the last solve
  std::vector<std::size_t> map_active_;               // the active points of the map's probe
};

}  // namespace vim::needle

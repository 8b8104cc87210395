// The band coupling of a bent needle (docs/needle-model.md, the flexible needle): the rows of a straight
// coupling (BandCoupling) whose lateral values also carry the needle's deflection at each station, set
// before each tissue solve by the flexible needle (FlexibleTissue). Everything else is the straight
// coupling's.
#pragma once

#include <memory>
#include <vector>
#include <vim/needle/coupling.hpp>

namespace vim::needle {

class DeflectedCoupling final : public NeedleCoupling<3> {
 public:
  explicit DeflectedCoupling(std::unique_ptr<NeedleCoupling<3>> straight);
  // The needle's lateral deflection at each shaft point (frame, normal to the axis; missing entries: 0).
  void set_deflection(std::vector<Vec> deflection) { deflection_ = std::move(deflection); }
  const std::vector<Vec>& deflection() const { return deflection_; }
  const NeedleCoupling<3>& straight() const { return *straight_; }

  // The straight coupling's values plus the deflection along the rows' lateral axes (columns 0 and 1;
  // the tip bearing's rows, axial only, are left as they are).
  void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                   std::vector<Vec>& held) const override;
  const fem::PointConstraint<3>& row_template(std::size_t j) const override {
    return straight_->row_template(j);
  }
  std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                   const fem::Solution<3>& solution) const override {
    return straight_->axial_forces(active, solution);
  }
  std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                 const fem::ElasticModel<3>& model) const override {
    return straight_->displacements(points, model);
  }
  void keep_offsets(const std::vector<Vec>& displacement) override { straight_->keep_offsets(displacement); }
  std::vector<Vec> tissue_displacements(const std::vector<Vec>& points, std::vector<Vec> mesh_values,
                                        const ShaftState& state,
                                        const fem::Solution<3>& solution) const override {
    return straight_->tissue_displacements(points, std::move(mesh_values), state, solution);
  }

 private:
  std::unique_ptr<NeedleCoupling<3>> straight_;
  std::vector<Vec> deflection_;
};

}  // namespace vim::needle

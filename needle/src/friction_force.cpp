// Force needle: every passed shaft point carries the axial friction force friction_per_length × (the
// shaft length it carries) and the point the tip pushes also the tip force; the axial values that give
// those forces are solved on the axial map (lateral displacement stays on the axis line).
#include "friction_laws.hpp"

namespace vim::needle {

namespace {

class ForceLaw final : public FrictionLaw {
 public:
  ForceLaw(double friction_per_length, double tip_force)
      : friction_per_length_(friction_per_length), tip_force_(tip_force) {}
  void start(std::size_t) override {}
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    for (std::size_t j : state.active) state.stick_to_needle(j);
    const AxialMap& map = tissue.axial_map();
    std::vector<double> target(state.axial.size(), 0.0);
    for (std::size_t j : state.active)
      target[j] = friction_per_length_ * state.carried[j] + (j == state.tip ? tip_force_ : 0.0);
    Eigen::VectorXd w = state.compact(state.axial);
    map.solve_free(w, std::vector<bool>(state.active.size(), true), state.compact(target));
    state.expand(w, state.axial);
    tissue.solve(state.axial);
    return {};
  }
  // The tip point carries tip_force.
  std::size_t tip_point(const ShaftState& state) const override { return state.tip; }
  LawDescription describe() const override {
    return {"force", "stick", {{"tip_force", tip_force_}, {"friction_per_length", friction_per_length_}}};
  }

 private:
  double friction_per_length_, tip_force_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_force_law(const FrictionOptions& spec) {
  return std::make_unique<ForceLaw>(spec.friction_per_length, spec.tip_force);
}

}  // namespace vim::needle

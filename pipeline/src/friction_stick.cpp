// Kinematic needle, stick: every picked-up shaft point moves with the rigid needle, u_j = (d − s_j)·a
// (δ behind the tip with a cutting distance δ). Pure stick drags the shaft's tissue along with the
// needle: the upper bound of tissue drag.
#include "friction_laws.hpp"

namespace vim::pipeline {

namespace {

class StickLaw final : public FrictionLaw {
 public:
  explicit StickLaw(double cutting_distance) : cutting_distance_(cutting_distance) {}
  void start(std::size_t) override {}
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    for (std::size_t j : state.active) state.stick_to_needle(j);
    tissue.solve(state.axial);
    return {};
  }
  // A stuck shaft advancing into linear elastic tissue pushes it: the axial force never falls.
  bool axial_force_never_falls() const override { return true; }
  void describe(nlohmann::json& r) const override {
    r["model"] = "kinematic";
    r["friction"] = "stick";
    r["cutting_distance"] = cutting_distance_;
  }

 private:
  double cutting_distance_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_stick_law(const NeedleSpec& spec) {
  return std::make_unique<StickLaw>(spec.cutting_distance);
}

}  // namespace vim::pipeline

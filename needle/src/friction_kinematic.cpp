// The kinematic needle's two laws, one active-set rule with two limits (friction_limits.cpp).
// Stick: every picked-up shaft point moves with the rigid needle, u_j = (d − s_j)·a (δ behind the tip
// with a cutting distance δ): the no-slip limit of stick-slip and the upper bound of tissue drag.
// Stick-slip: a shaft point sticks to the needle until its axial load exceeds max_shear_per_length ×
// (the shaft length it carries); then it slides, its axial value solved on the axial map so that its
// load equals that limit, and its slip accumulates (u_j = d − s_j − slip_j). Active set: a sliding
// point whose limit would need it to move ahead of the needle sticks again. In both, the point the tip
// pushes (a cutting force F_c > 0) has the limit F_c: the tissue at the tip is pushed until its load
// reaches F_c, then cut.
#include <limits>

#include "friction_laws.hpp"

namespace vim::needle {

namespace {

class KinematicLaw final : public FrictionLaw {
 public:
  KinematicLaw(const FrictionOptions& spec, bool stick) : spec_(spec), stick_(stick) {}
  void start(std::size_t n) override {
    sliding_.assign(n, false);
    sign_.assign(n, 1.0);
    work_.reserve(n);
    limit_.assign(n, stick_ ? std::numeric_limits<double>::infinity() : 0.0);
  }
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    friction_limits(state, spec_, stick_, limit_);
    return settle_active_set(state, tissue, limit_, sliding_, sign_, spec_.max_sweeps, work_);
  }
  // Stick has points that slide only where the tip cuts.
  bool has_active_set() const override { return !stick_ || spec_.cuts(); }
  // A stuck shaft advancing into linear elastic tissue pushes it: the axial force never falls.
  bool axial_force_never_falls() const override { return stick_; }
  bool tip_cuts() const override { return spec_.cuts(); }
  LawDescription describe() const override {
    LawDescription d{"kinematic", stick_ ? "stick" : "stick-slip", {}};
    if (!stick_) d.parameters.emplace_back("max_shear_per_length", spec_.max_shear_per_length);
    d.parameters.emplace_back("cutting_distance", spec_.cutting_distance);
    d.parameters.emplace_back("cutting_force", spec_.cutting_force);
    return d;
  }

 private:
  FrictionOptions spec_;  // the per-point values
  bool stick_;
  std::vector<bool> sliding_;  // per shaft point: force-controlled at ±limit
  std::vector<double> sign_, limit_;
  ActiveSetWorkspace work_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_stick_law(const FrictionOptions& spec) {
  return std::make_unique<KinematicLaw>(spec, true);
}

std::unique_ptr<FrictionLaw> make_stick_slip_law(const FrictionOptions& spec) {
  return std::make_unique<KinematicLaw>(spec, false);
}

}  // namespace vim::needle

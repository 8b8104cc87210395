// Kinematic needle, stick: every picked-up shaft point moves with the rigid needle, u_j = (d − s_j)·a
// (δ behind the tip with a cutting distance δ). Pure stick drags the shaft's tissue along with the
// needle: the no-slip limit of stick-slip and the upper bound of tissue drag. The point the tip pushes
// (a cutting force F_c > 0) moves with the needle until its load reaches F_c, then is held at F_c.
#include <limits>

#include "friction_laws.hpp"

namespace vim::needle {

namespace {

class StickLaw final : public FrictionLaw {
 public:
  explicit StickLaw(const FrictionOptions& spec)
      : spec_(spec),
        cutting_distance_(spec.cutting_distance),
        cutting_force_(spec.cutting_force),
        max_sweeps_(spec.max_sweeps) {}
  void start(std::size_t n) override {
    sliding_.assign(n, false);
    sign_.assign(n, 1.0);
    work_.reserve(n);
    limit_.assign(n, std::numeric_limits<double>::infinity());
  }
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    friction_limits(state, spec_, true, limit_);
    return settle_active_set(state, tissue, limit_, sliding_, sign_, max_sweeps_, work_);
  }
  bool has_active_set() const override { return spec_.cuts(); }
  // A stuck shaft advancing into linear elastic tissue pushes it: the axial force never falls.
  bool axial_force_never_falls() const override { return true; }
  bool tip_cuts() const override { return spec_.cuts(); }
  LawDescription describe() const override {
    return {
        "kinematic", "stick", {{"cutting_distance", cutting_distance_}, {"cutting_force", cutting_force_}}};
  }

 private:
  FrictionOptions spec_;  // the per-point values
  double cutting_distance_, cutting_force_;
  int max_sweeps_;
  std::vector<bool> sliding_;
  std::vector<double> sign_, limit_;
  ActiveSetWorkspace work_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_stick_law(const FrictionOptions& spec) {
  return std::make_unique<StickLaw>(spec);
}

}  // namespace vim::needle

// Kinematic needle, stick-slip: a shaft point sticks to the needle until its axial load exceeds
// max_shear_per_length × (the shaft length it carries); then it slides, its axial value solved on the
// axial map so that its load equals that limit, and its slip accumulates (u_j = d − s_j − slip_j).
// Active set: a sliding point whose limit would need it to move ahead of the needle sticks again. The
// point the tip pushes (a cutting force F_c > 0) has the limit F_c instead: the tissue at the tip is
// pushed until its load reaches F_c, then cut.
#include <algorithm>

#include "friction_laws.hpp"

namespace vim::needle {

namespace {

class StickSlipLaw final : public FrictionLaw {
 public:
  explicit StickSlipLaw(const FrictionOptions& spec)
      : spec_(spec),
        max_shear_per_length_(spec.max_shear_per_length),
        max_sweeps_(std::max(1, spec.max_sweeps)),
        cutting_distance_(spec.cutting_distance),
        cutting_force_(spec.cutting_force) {}
  void start(std::size_t n) override {
    sliding_.assign(n, false);
    sign_.assign(n, 1.0);
    work_.reserve(n);
    limit_.assign(n, 0.0);
  }
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    friction_limits(state, spec_, false, limit_);
    return settle_active_set(state, tissue, limit_, sliding_, sign_, max_sweeps_, work_);
  }
  bool has_active_set() const override { return true; }
  bool tip_cuts() const override { return spec_.cuts(); }
  LawDescription describe() const override {
    return {"kinematic",
            "stick-slip",
            {{"max_shear_per_length", max_shear_per_length_},
             {"cutting_distance", cutting_distance_},
             {"cutting_force", cutting_force_}}};
  }

 private:
  FrictionOptions spec_;  // the per-point values
  double max_shear_per_length_;
  int max_sweeps_;
  double cutting_distance_, cutting_force_;
  std::vector<bool> sliding_;  // per shaft point: force-controlled at ±limit
  std::vector<double> sign_, limit_;
  ActiveSetWorkspace work_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_stick_slip_law(const FrictionOptions& spec) {
  return std::make_unique<StickSlipLaw>(spec);
}

}  // namespace vim::needle

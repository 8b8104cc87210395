// Kinematic needle, stick-slip: a shaft point sticks to the needle until its axial load exceeds
// max_shear_per_length × (the shaft length it carries); then it slides, its axial value solved on the
// axial map so that its load equals that limit, and its slip accumulates (u_j = d − s_j − slip_j).
// Active set: a sliding point whose limit would need it to move ahead of the needle sticks again. The
// limits of all points sum to max_shear_per_length × depth.
#include <algorithm>
#include <cmath>

#include "friction_laws.hpp"

namespace vim::pipeline {

namespace {

class StickSlipLaw final : public FrictionLaw {
 public:
  StickSlipLaw(double max_shear_per_length, int max_sweeps, double cutting_distance)
      : max_shear_per_length_(max_shear_per_length),
        max_sweeps_(std::max(1, max_sweeps)),
        cutting_distance_(cutting_distance) {}
  void start(std::size_t n) override {
    sliding_.assign(n, false);
    sign_.assign(n, 1.0);
    limit_.assign(n, 0.0);
  }
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override;
  bool has_active_set() const override { return true; }
  void describe(nlohmann::json& r) const override {
    r["model"] = "kinematic";
    r["friction"] = "stick-slip";
    r["max_shear_per_length"] = max_shear_per_length_;
    r["cutting_distance"] = cutting_distance_;
  }

 private:
  bool exceeds(double force, double limit) const { return std::abs(force) > limit * (1.0 + 1e-9); }
  double max_shear_per_length_;
  int max_sweeps_;
  double cutting_distance_;
  std::vector<bool> sliding_;  // per shaft point: force-controlled at ±limit
  std::vector<double> sign_, limit_;
};

FrictionStep StickSlipLaw::update(ShaftState& state, TissueResponse& tissue) {
  // Try sticking first (sliding points keep their slipped value).
  for (std::size_t j : state.active)
    if (!sliding_[j]) state.stick_to_needle(j);
  for (std::size_t j : state.active) limit_[j] = max_shear_per_length_ * state.carried[j];
  bool need = false;
  for (std::size_t j : state.active) need = need || sliding_[j];
  if (!need) {
    const std::vector<double> fa = tissue.solve(state.axial);
    for (std::size_t j : state.active) need = need || exceeds(fa[j], limit_[j]);
  }
  if (!need) return {};
  // The active-set problem on the axial map: sliding points carry ±limit, stuck points move with the
  // needle.
  const AxialMap& map = tissue.axial_map();
  const std::size_t m = state.active.size();
  Eigen::VectorXd wc = state.compact(state.axial), ws = state.compact(state.stick),
                  lim = state.compact(limit_);
  std::vector<bool> sl(m);
  Eigen::VectorXd sg(m);
  for (std::size_t i = 0; i < m; ++i) {
    sl[i] = sliding_[state.active[i]];
    sg[i] = sign_[state.active[i]];
  }
  FrictionStep step;
  step.settled = false;
  for (; step.sweeps < max_sweeps_ && !step.settled; ++step.sweeps) {
    map.solve_free(wc, sl, sg.cwiseProduct(lim));
    const Eigen::VectorXd f = map(wc);
    bool changed = false;
    for (std::size_t i = 0; i < m; ++i) {
      if (!sl[i] && exceeds(f[i], lim[i])) {
        sl[i] = true;
        sg[i] = f[i] > 0.0 ? 1.0 : -1.0;
        changed = true;
      } else if (sl[i] && (wc[i] - ws[i]) * sg[i] > 1e-12 * std::max(1.0, std::abs(ws[i]))) {
        // Holding the limit would need the point to move ahead of the needle: it sticks again.
        sl[i] = false;
        wc[i] = ws[i];
        changed = true;
      }
    }
    step.settled = !changed;
  }
  state.expand(wc, state.axial);
  for (std::size_t i = 0; i < m; ++i) {
    sliding_[state.active[i]] = sl[i];
    sign_[state.active[i]] = sg[i];
  }
  tissue.solve(state.axial);
  return step;
}

}  // namespace

std::unique_ptr<FrictionLaw> make_stick_slip_law(const NeedleSpec& spec, int max_sweeps) {
  return std::make_unique<StickSlipLaw>(spec.max_shear_per_length, max_sweeps, spec.cutting_distance);
}

}  // namespace vim::pipeline

// Force needle: every passed shaft point carries the axial friction force friction_per_length × (the
// shaft length it carries) and the point the tip pushes also the tip force; the axial values that give
// those forces are solved on the axial map (lateral displacement stays on the axis line).
#include <algorithm>

#include "friction_laws.hpp"

namespace vim::needle {

namespace {

class ForceLaw final : public FrictionLaw {
 public:
  ForceLaw(double friction_per_length, double tip_force)
      : friction_per_length_(friction_per_length), tip_force_(tip_force) {}
  void start(std::size_t n) override { reserve(n); }
  FrictionStep update(ShaftState& state, TissueResponse& tissue) override {
    for (std::size_t j : state.active) state.stick_to_needle(j);
    const std::size_t m = state.active.size();
    reserve(m);
    auto w = w_.head(static_cast<Eigen::Index>(m)), target = target_.head(static_cast<Eigen::Index>(m));
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t j = state.active[i];
      w[static_cast<Eigen::Index>(i)] = state.axial[j];
      target[static_cast<Eigen::Index>(i)] =
          friction_per_length_ * state.carried[j] + (j == state.tip ? tip_force_ : 0.0);
    }
    // A nonlinear tissue: map (the tangent at the last solve) and solve until the forces meet the targets.
    FrictionStep step;
    for (;; ++step.rounds) {
      tissue.axial_map().solve_free(w, free_, target, work_);
      for (std::size_t i = 0; i < m; ++i) state.axial[state.active[i]] = w[static_cast<Eigen::Index>(i)];
      const std::vector<double>& f = tissue.solve(state.axial);
      if (!tissue.nonlinear()) break;
      double scale = 0.0, misfit = 0.0;
      for (std::size_t i = 0; i < m; ++i) {
        const double t = target[static_cast<Eigen::Index>(i)];
        scale = std::max({scale, std::abs(t), std::abs(f[state.active[i]])});
        misfit = std::max(misfit, std::abs(f[state.active[i]] - t));
      }
      if (misfit <= kNonlinearForceTolerance * scale) break;
      if (step.rounds + 1 >= kMaxNonlinearRounds) {
        step.settled = false;
        break;
      }
    }
    return step;
  }
  // The tip point carries tip_force.
  std::size_t tip_point(const ShaftState& state) const override { return state.tip; }
  LawDescription describe() const override {
    return {"force", "stick", {{"tip_force", tip_force_}, {"friction_per_length", friction_per_length_}}};
  }

 private:
  // Work vectors for n active points (allocation-free steps once reserved).
  void reserve(std::size_t n) {
    if (static_cast<std::size_t>(w_.size()) >= n) return;
    w_.resize(static_cast<Eigen::Index>(n)), target_.resize(static_cast<Eigen::Index>(n));
    free_.assign(n, true);
    work_.reserve(static_cast<Eigen::Index>(n));
  }
  double friction_per_length_, tip_force_;
  Eigen::VectorXd w_, target_;
  std::vector<bool> free_;
  AxialMap::Work work_;
};

}  // namespace

std::unique_ptr<FrictionLaw> make_force_law(const FrictionOptions& spec) {
  return std::make_unique<ForceLaw>(spec.friction_per_length, spec.tip_force);
}

}  // namespace vim::needle

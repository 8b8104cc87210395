// The active set of the kinematic laws (vim/needle/active_set.hpp).
#include <algorithm>
#include <cmath>
#include <vim/needle/active_set.hpp>

namespace vim::needle {

// The active-set problem of the kinematic laws on the axial map: a point sticks (moves with the needle)
// unless its axial load exceeds its limit; then it slides, its value solved so that its load equals
// ±limit. A sliding point whose limit would need it to move ahead of the needle sticks again. One
// solve when every point can stick; the map (m + 1 solves when m changes) otherwise.
FrictionStep settle_active_set(ShaftState& state, TissueResponse& tissue, const std::vector<double>& limit,
                               std::vector<bool>& sliding, std::vector<double>& sign, int max_sweeps) {
  const auto exceeds = [](double force, double lim) { return std::abs(force) > lim * (1.0 + 1e-9); };
  // Try sticking first (sliding points keep their slipped value; an unlimited point never slides).
  for (std::size_t j : state.active) {
    if (!std::isfinite(limit[j])) sliding[j] = false;
    if (!sliding[j]) state.stick_to_needle(j);
  }
  bool need = false;
  for (std::size_t j : state.active) need = need || sliding[j];
  if (!need) {
    const std::vector<double> fa = tissue.solve(state.axial);
    for (std::size_t j : state.active) need = need || exceeds(fa[j], limit[j]);
  }
  if (!need) return {};
  const AxialMap& map = tissue.axial_map();
  const std::size_t m = state.active.size();
  Eigen::VectorXd wc = state.compact(state.axial), ws = state.compact(state.stick),
                  lim = state.compact(limit);
  std::vector<bool> sl(m);
  Eigen::VectorXd sg(m);
  for (std::size_t i = 0; i < m; ++i) {
    sl[i] = sliding[state.active[i]];
    sg[i] = sign[state.active[i]];
  }
  FrictionStep step;
  step.settled = false;
  for (; step.sweeps < std::max(1, max_sweeps) && !step.settled; ++step.sweeps) {
    map.solve_free(wc, sl, sg.cwiseProduct(lim));
    const Eigen::VectorXd f = map(wc);
    bool changed = false;
    for (std::size_t i = 0; i < m; ++i) {
      if (!sl[i] && exceeds(f[i], lim[i])) {
        sl[i] = true;
        sg[i] = f[i] > 0.0 ? 1.0 : -1.0;
        changed = true;
      } else if (sl[i] && (wc[i] - ws[i]) * sg[i] > 1e-12 * std::max(1.0, std::abs(ws[i]))) {
        sl[i] = false;
        wc[i] = ws[i];
        changed = true;
      }
    }
    step.settled = !changed;
  }
  state.expand(wc, state.axial);
  for (std::size_t i = 0; i < m; ++i) {
    sliding[state.active[i]] = sl[i];
    sign[state.active[i]] = sg[i];
  }
  tissue.solve(state.axial);
  return step;
}

}  // namespace vim::needle

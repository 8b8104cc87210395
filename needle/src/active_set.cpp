// The active set of the kinematic laws (vim/needle/active_set.hpp).
#include <algorithm>
#include <cmath>
#include <vim/needle/active_set.hpp>

namespace vim::needle {

void ActiveSetWorkspace::reserve(std::size_t n_points) {
  const auto n = static_cast<Eigen::Index>(n_points);
  if (w.size() < n) {
    for (Eigen::VectorXd* v : {&w, &stick, &limit, &sign, &target, &force}) v->resize(n);
    sliding.resize(n_points);
  }
  map.reserve(n);
}

// The active-set problem of the kinematic laws on the axial map: a point sticks (moves with the needle)
// unless its axial load exceeds its limit; then it slides, its value solved so that its load equals
// ±limit. A sliding point whose limit would need it to move ahead of the needle sticks again. One
// solve when every point can stick; the map (m + 1 solves when m changes) otherwise.
FrictionStep settle_active_set(ShaftState& state, TissueResponse& tissue, const std::vector<double>& limit,
                               std::vector<bool>& sliding, std::vector<double>& sign, int max_sweeps,
                               ActiveSetWorkspace& work) {
  const auto exceeds = [](double force, double lim) { return std::abs(force) > lim * (1.0 + 1e-9); };
  // Try sticking first (sliding points keep their slipped value; an unlimited point never slides).
  for (std::size_t j : state.active) {
    if (!std::isfinite(limit[j])) sliding[j] = false;
    if (!sliding[j]) state.stick_to_needle(j);
  }
  bool need = false;
  for (std::size_t j : state.active) need = need || sliding[j];
  if (!need) {
    const std::vector<double>& fa = tissue.solve(state.axial);
    for (std::size_t j : state.active) need = need || exceeds(fa[j], limit[j]);
  }
  if (!need) return {};
  const std::size_t m = state.active.size();
  work.reserve(m);
  const auto mi = static_cast<Eigen::Index>(m);
  auto wc = work.w.head(mi), ws = work.stick.head(mi), lim = work.limit.head(mi), sg = work.sign.head(mi),
       target = work.target.head(mi), f = work.force.head(mi);
  std::vector<bool>& sl = work.sliding;
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = state.active[i];
    const auto e = static_cast<Eigen::Index>(i);
    wc[e] = state.axial[j], ws[e] = state.stick[j], lim[e] = limit[j], sg[e] = sign[j];
    sl[i] = sliding[j];
  }
  FrictionStep step;
  for (;; ++step.rounds) {
    const AxialMap& map = tissue.axial_map();
    step.settled = false;
    for (int sweeps = 0; sweeps < std::max(1, max_sweeps) && !step.settled; ++sweeps, ++step.sweeps) {
      target = sg.cwiseProduct(lim);
      map.solve_free(wc, sl, target, work.map);
      map.apply(wc, f);
      bool changed = false;
      for (std::size_t i = 0; i < m; ++i) {
        const auto e = static_cast<Eigen::Index>(i);
        if (!sl[i] && exceeds(f[e], lim[e])) {
          sl[i] = true;
          sg[e] = f[e] > 0.0 ? 1.0 : -1.0;
          changed = true;
        } else if (sl[i] && (wc[e] - ws[e]) * sg[e] > 1e-12 * std::max(1.0, std::abs(ws[e]))) {
          sl[i] = false;
          wc[e] = ws[e];
          changed = true;
        }
      }
      step.settled = !changed;
    }
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t j = state.active[i];
      const auto e = static_cast<Eigen::Index>(i);
      state.axial[j] = wc[e], sliding[j] = sl[i], sign[j] = sg[e];
    }
    const std::vector<double>& fa = tissue.solve(state.axial);
    if (!tissue.nonlinear() || !step.settled) break;
    // The nonlinear solve's forces against the limits the map's settling met.
    double scale = 0.0, misfit = 0.0;
    for (std::size_t i = 0; i < m; ++i) {
      const auto e = static_cast<Eigen::Index>(i);
      const double force = fa[state.active[i]];
      scale = std::max(scale, std::abs(force));
      if (std::isfinite(lim[e])) scale = std::max(scale, lim[e]);
      misfit = std::max(misfit, sl[i] ? std::abs(force - sg[e] * lim[e]) : std::abs(force) - lim[e]);
    }
    if (misfit <= kNonlinearForceTolerance * scale) break;
    if (step.rounds + 1 >= kMaxNonlinearRounds) {
      step.settled = false;
      break;
    }
  }
  return step;
}

}  // namespace vim::needle

// The active set of the kinematic friction laws (stick and stick-slip): which shaft points stick to
// the needle and which slide at their friction limit.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>
#include <vim/needle/axial_map.hpp>
#include <vim/needle/shaft_state.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

// What a law did at one step (stick-slip: the active-set sweeps and whether the set settled).
// On a nonlinear tissue, rounds: the tissue solves after a settling on the axial map (each round takes
// the map at the last solve's state).
struct FrictionStep {
  int sweeps = 0;
  bool settled = true;
  int rounds = 0;
};

// The work vectors of settle_active_set, kept by the law between steps: once reserved for the shaft's
// points (FrictionLaw::start), a step allocates nothing (the real-time needle's frames).
struct ActiveSetWorkspace {
  Eigen::VectorXd w, stick, limit, sign, target, force;  // per active point (compact order)
  std::vector<bool> sliding;                             // per active point
  AxialMap::Work map;
  void reserve(std::size_t n_points);
};

// Every active point sticks (moves with the needle: state.stick) unless its axial load exceeds
// limit[j] (per point; +∞: always sticks); then it slides, its value solved on the tissue's axial map
// so that its load equals ±limit. A sliding point whose limit would need it to move ahead of the
// needle sticks again. `sliding` and `sign` (per point) are kept between steps by the law; at most
// max_sweeps sweeps (≥ 1). One solve when every point can stick; the map (m + 1 solves when m
// changes) otherwise. Leaves the tissue solved with the final values. On a nonlinear tissue the map is
// the tangent at the last solve: the settling on it and the solve are repeated (the sliding and sign
// kept, the map taken anew) until the solve's forces meet the limits — sliding points' within
// kNonlinearForceTolerance of ±limit, the others within their limit — and the set no longer changes; at
// most kMaxNonlinearRounds rounds, else the step is returned unsettled.
FrictionStep settle_active_set(ShaftState& state, TissueResponse& tissue, const std::vector<double>& limit,
                               std::vector<bool>& sliding, std::vector<double>& sign, int max_sweeps,
                               ActiveSetWorkspace& work);

}  // namespace vim::needle

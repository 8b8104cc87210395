// The one interface between the needle and the tissue. The insertion stepping and the friction laws
// see the tissue only through it: the condensed compliance of the coupling rows. A step sets the axial
// value of every active shaft point (how far along the needle axis its tissue is moved) and asks the
// tissue for the axial force each point's rows then carry; force control needs the affine map from
// those values to those forces.
//
// Implementations: the linear elastic model condensed onto the needle's rows
// (fem::CondensedConstraints, one dense Schur solve per call; pipeline's NeedleInsertion), or its
// monolithic reference; the real-time needle's condensed region (HapticNeedle); the neo-Hookean model,
// one Newton solve per call (NeoHookeanTissue), whose axial_map() is the tangent at the last solve's
// state or a kept one that still predicts its forces (nonlinear(): the laws repeat map and solve until
// the forces agree). A flexible needle adds its
// own compliance to the rows behind this interface. Neither touches the stepping.
#pragma once

#include <cstddef>
#include <vector>
#include <vim/needle/axial_map.hpp>
#include <vim/needle/shaft_state.hpp>

namespace vim::needle {

class TissueResponse {
 public:
  virtual ~TissueResponse() = default;
  // One tissue solve with the active points at `axial` (one entry per shaft point; only the active
  // points' entries are read); the axial force on the body per shaft point (0 for points not active),
  // valid until the next call. The last call of a step is the step's solution.
  virtual const std::vector<double>& solve(const std::vector<double>& axial) = 0;
  // The affine map from the active points' axial values to their axial forces (axial_map.hpp), probed
  // with m + 1 solves when the active points (m of them) have changed since the last probe.
  virtual const AxialMap& axial_map() = 0;
  // A nonlinear tissue: its axial map is the tangent at the last solve's state, so a law that solves
  // forces on the map repeats map and solve until the solve's forces meet them (settle_active_set).
  virtual bool nonlinear() const { return false; }
};

// The rounds of map and solve a law makes on a nonlinear tissue before it gives up on a step, and the
// agreement it asks of the solve's forces (relative to the largest force or limit of the step).
inline constexpr int kMaxNonlinearRounds = 50;
inline constexpr double kNonlinearForceTolerance = 1e-8;

// The axial map of a linear `tissue` over the active points of `state` (n_points shaft points), probed
// through its solve() with AxialMap::probe at `step`.
AxialMap probe_axial_map(TissueResponse& tissue, const ShaftState& state, std::size_t n_points, double step);

}  // namespace vim::needle

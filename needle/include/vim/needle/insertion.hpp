// The insertion stepping of one needle (docs/architecture.md, the needle model): which shaft points
// are on the needle at each step, the value that moves each with the needle and the shaft length each
// carries, and the law's solve through the tissue interface (TissueResponse). It knows nothing about
// the tissue behind that interface, the files or the scenario.
//
// Each point (3D: a band station) stands for its band [b_j, e_j] of the path (3D: its segment; 2D:
// from its segment's start to the point). Positions are current ones, b_j + ū_j (ū_j the axial
// displacement the point's rows hold in the previous step's solution: tissue ahead of the tip is pushed
// before it is pierced), and the tip is the needle's cutting distance δ behind its end (cut = depth − δ).
//  * A point joins the shaft when the tip has passed its band (e_j + ū_j < cut), at its current
//    displacement plus the needle's travel since (cut − e_j): no jump, so the force does not drop.
//  * With a law whose tip cuts (a cutting force F_c > 0) the point whose band the tip has entered
//    (b_j + ū_j < cut) is the tissue the tip pushes (ShaftState::cutting): it joins the active set (at
//    cut − b_j) and moves with the needle until its load reaches F_c, then is held at F_c by the law;
//    it becomes a shaft point once the tip has passed its band. Otherwise that tissue is free (cut
//    without resistance).
// Each point carries its segment of the shaft as far as the tip has passed (the last one everything up
// to the tip).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>
#include <vim/needle/friction_law.hpp>
#include <vim/needle/needle_options.hpp>
#include <vim/needle/shaft.hpp>

namespace vim::needle {

template <int dim>
class Insertion {
 public:
  // The shaft points of the needle's coupling (3D: band stations centred on their segments; 2D: points
  // on the axis, each standing for the path from the previous one); the law of options.friction.
  Insertion(const NeedleOptions<dim>& options, std::vector<ShaftPoint<dim>> shaft);

  // The needle's travel at step k of options.steps.
  double depth(int k) const;
  // The active set at needle travel `depth` (`travel` since the last step): the points joined before,
  // the point the tip pushes (if any) and those the tip reaches now. held_axial(j): the axial
  // displacement point j's rows hold in the last solution (0 before any).
  void pick_up(double depth, double travel, const std::function<double(std::size_t)>& held_axial);
  // The law's solve of the step through the tissue (its last solve is the step's solution).
  FrictionStep solve(TissueResponse& tissue) { return law_->update(state_, tissue); }

  const ShaftState& state() const { return state_; }
  const FrictionLaw& law() const { return *law_; }
  const std::vector<ShaftPoint<dim>>& shaft() const { return shaft_; }
  // The active point whose force is the tip's (FrictionLaw::tip_point).
  std::size_t tip_point() const { return law_->tip_point(state_); }

 private:
  NeedleOptions<dim> options_;
  std::vector<ShaftPoint<dim>> shaft_;
  std::vector<double> start_;  // arc length where each point's shaft segment (and band) starts
  std::vector<double> end_;    // arc length where its band ends: the tip has passed it there
  std::unique_ptr<FrictionLaw> law_;
  ShaftState state_;
  std::vector<bool> picked_;
  bool cuts_ = false;  // the tip pushes a point until it cuts it
};

}  // namespace vim::needle

// The insertion stepping of one needle (docs/architecture.md, the needle model; docs/needle-model.md,
// the tip bearing and the joining rule): which shaft points are on the needle at each step, the value
// that moves each with the needle and the shaft length each carries, the tissue the tip presses, and
// the law's solve through the tissue interface (TissueResponse). It knows nothing about the tissue
// behind that interface, the files or the scenario.
//
// The tip is the needle's cutting distance δ behind its end (cut = depth − δ). The front f is the
// arc length, in the rest configuration, of the tissue at the tip: what the tip has cut.
//
// 3D (band stations centred on their segments [b_j, e_j]):
//  * With tip rows (a cutting force F_c > 0): the tip presses the disk row nearest the front
//    (ShaftState::cutting) at the value cut − f (it moves with the needle: nothing more is cut) unless
//    its force would exceed F_c; the law then holds it at F_c and the tip has cut up to f = cut − w,
//    w the row's solved value (the indentation); the disk follows the front at the next step. Without
//    tip rows the tissue at the tip is cut without resistance: f = cut − ū, ū the axial displacement
//    of the tissue there.
//  * A station joins as soon as the front passes its band's start and carries the cut part of its
//    segment, L_j = min(f, e_j) − b_j (friction from the first millimetre). Its value is the mean over
//    that part of the tissue's stick displacement, cut − s for the tissue at s (which met the tip
//    where the tip now is, less what it has travelled since): no jump at a join. Tissue that was cut
//    earlier keeps its own value (slip included): the value grows as
//      g ← [L_old (g + travel) + ΔL (cut − s̄_new)] / L_new,  s̄_new the centre of the newly cut part.
// 2D (points on the axis, each standing for the path from the previous one to it): a point joins when
// the tip has passed it (at cut − s_j, its stick value: a point has no extent), the last one carrying
// everything up to the tip; with F_c > 0 the point whose band the tip has entered is the tissue it
// pushes (at cut − b_j) until its load reaches F_c (2D has no end bearing: a plane-strain blade has no
// punch of finite compliance).
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
  // on the axis, each standing for the path from the previous one); 3D: the tip rows (disk centres
  // and their arc lengths, points shaft.size() + k), used when the law's tip cuts; the law of
  // options.friction.
  Insertion(const NeedleOptions<dim>& options, std::vector<ShaftPoint<dim>> shaft,
            std::vector<ShaftPoint<dim>> tip_rows = {});

  // The needle's travel at step k of options.steps.
  double depth(int k) const;
  // The active set at needle travel `depth` (`travel` since the last step): the points joined before,
  // the tissue the tip presses (if any) and the points the front reaches now. held_axial(j): the axial
  // displacement point j's rows hold in the last solution (0 before any).
  void pick_up(double depth, double travel, const std::function<double(std::size_t)>& held_axial);
  // Withdrawal: the needle back out to travel `depth` (`travel` < 0 since the last step). Every point
  // still on the shaft moves with it (its stick value shifts by the travel) unless the law lets it slip
  // (the active set then finds friction reversed); the tip presses nothing; the tissue the tip passes
  // on the way out leaves the shaft: 3D, a station keeps the part of its segment behind the tip,
  // min(carried, cut − b_j), its stick value the mean of the stick profile (cut − s) over that part
  // (the join rule reversed); 2D, a point leaves once the tip is back at it. Without slip, the state at
  // a depth is the insertion's at that depth.
  void withdraw(double depth, double travel);
  // The law's solve of the step through the tissue (its last solve is the step's solution).
  FrictionStep solve(TissueResponse& tissue);

  const ShaftState& state() const { return state_; }
  const FrictionLaw& law() const { return *law_; }
  const std::vector<ShaftPoint<dim>>& shaft() const { return shaft_; }
  // Shaft points and tip rows: the coupling's points.
  std::size_t n_points() const { return shaft_.size() + tips_.size(); }
  // The active point whose force is the tip's (FrictionLaw::tip_point).
  std::size_t tip_point() const { return law_->tip_point(state_); }

 private:
  void pick_up_points(double cut, double depth, const std::function<double(std::size_t)>& held_axial);
  void pick_up_bands(double cut, double travel, const std::function<double(std::size_t)>& held_axial);
  double press_tip(double cut, double travel);
  void join_stations(double cut, double reach);
  void list_active();

  NeedleOptions<dim> options_;
  std::vector<ShaftPoint<dim>> shaft_, tips_;
  std::vector<double> start_;  // arc length where each point's shaft segment (and band) starts
  std::vector<double> end_;    // arc length where its band ends
  std::unique_ptr<FrictionLaw> law_;
  ShaftState state_;
  std::vector<bool> picked_;
  bool cuts_ = false;   // the tip pushes the tissue until it cuts it
  double cut_ = 0.0;    // the tip's travel at this step
  double reach_ = 0.0;  // 3D: the front the stations took at this step
};

}  // namespace vim::needle

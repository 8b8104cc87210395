// The shaft points as the insertion stepping hands them to a friction law at one step.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <vector>

namespace vim::needle {

// Per-point vectors have one entry per shaft point (in shaft order); only those of `active` points mean
// anything at this step.
struct ShaftState {
  std::vector<std::size_t> active;  // points on the needle at this step, in shaft order
  std::size_t tip = 0;              // the last active point (the one nearest the tip)
  // The active point the tip pushes until it is cut (kinematic model with a cutting force): it moves
  // with the needle until its axial force reaches the cutting force, then it is held at that force
  // (the law's limit for it). None (any index ≥ the number of points) when the cutting force is 0: the
  // tissue at the tip is then cut without resistance and not held.
  std::size_t cutting = std::numeric_limits<std::size_t>::max();
  std::vector<bool> joined;     // picked up at this step
  std::vector<double> axial;    // axial constraint value: kept between steps, set by the law
  std::vector<double> stick;    // the value that moves the point with the needle at this step
  std::vector<double> carried;  // shaft length the point carries (its segment up to the tip)
  // Per shaft point (tip rows excluded): the arc length at rest where its carried interval starts; it
  // carries [start, start + carried].
  std::vector<double> start;
  // 3D: the arc length, at rest, of the tissue at the tip (what the tip has cut).
  double front = 0.0;
  // The point the tip pushes is held at the cutting force (the tip cuts) in the last solve.
  bool tip_cutting = false;

  // Moves a point with the needle (it sticks).
  void stick_to_needle(std::size_t j) { axial[j] = stick[j]; }
  // The entries of the active points, in the order of `active`, and back.
  Eigen::VectorXd compact(const std::vector<double>& v) const;
  void expand(const Eigen::VectorXd& c, std::vector<double>& v) const;
};

}  // namespace vim::needle

// The insertion stepping (vim/needle/insertion.hpp) against a tissue solved by hand (every point on its
// own axial spring, tests/needle/springs.hpp), for which the stick values, the carried lengths and the
// tip's indentation follow in closed form:
//  * a stuck band station carries the cut part [b, min(e, f)] of its segment and holds the mean over
//    it of the tissue's stick displacement cut − s (tissue that stays where the tip met it, moved by
//    the needle's travel since), f = cut − ū the front (ū = 0 here);
//  * a tip row on a spring k presses with k·(cut − f) until that exceeds F_c; then it is held at F_c
//    (indentation F_c/k) and the front is cut − F_c/k at every later step.
#include <gtest/gtest.h>

#include <algorithm>
#include <vim/needle/insertion.hpp>

#include "springs.hpp"

using namespace vim;
using namespace vim::needle;
using vim::needle::test::Springs;

namespace {

// Stations of length 2 tiling [0, 10] (centres 1, 3, …, 9), 3D.
std::vector<ShaftPoint<3>> five_stations() {
  std::vector<ShaftPoint<3>> shaft;
  for (int j = 0; j < 5; ++j) shaft.push_back({Vec<3>(0.0, 0.0, 2.0 * j + 1.0), 2.0 * j + 1.0, 2.0});
  return shaft;
}

NeedleOptions<3> options_for(const char* law, int steps, double cutting_distance) {
  NeedleOptions<3> o;
  o.path.depth = 10.0;
  o.steps = steps;
  o.friction.law = law;
  o.friction.cutting_distance = cutting_distance;
  return o;
}

}  // namespace

TEST(Insertion, StationsJoinAtTheMeanStickValueOfTheirCutPart) {
  Insertion<3> ins(options_for("stick", 7, 0.7), five_stations());
  Springs tissue(std::vector<double>(5, 3.0), ins.state());
  double prev = 0.0;
  for (int k = 1; k <= 7; ++k) {
    const double d = ins.depth(k), cut = d - 0.7;
    ins.pick_up(d, d - prev, [](std::size_t) { return 0.0; });
    ins.solve(tissue);
    prev = d;
    const ShaftState& s = ins.state();
    for (std::size_t j = 0; j < 5; ++j) {
      const double b = 2.0 * static_cast<double>(j);
      const bool on = cut > b;
      ASSERT_EQ(std::count(s.active.begin(), s.active.end(), j) == 1, on) << "step " << k << " station " << j;
      if (!on) continue;
      const double carried = std::min(2.0, cut - b);
      EXPECT_NEAR(s.carried[j], carried, 1e-12) << "step " << k << " station " << j;
      // mean of cut − s over [b, b + carried]
      EXPECT_NEAR(s.axial[j], cut - (b + 0.5 * carried), 1e-12) << "step " << k << " station " << j;
    }
  }
}

// Stick-slip on the springs: every station force stays within q × its carried length, and the total
// (the needle's axial force) never falls.
TEST(Insertion, StickSlipForceWithinTheCarriedLimitNeverFalls) {
  NeedleOptions<3> o = options_for("stick-slip", 13, 0.0);
  o.friction.max_shear_per_length = 1.0;
  Insertion<3> ins(o, five_stations());
  Springs tissue({3.0, 0.5, 3.0, 0.2, 3.0}, ins.state());
  double prev = 0.0, total_prev = 0.0;
  for (int k = 1; k <= 13; ++k) {
    const double d = ins.depth(k);
    ins.pick_up(d, d - prev, [](std::size_t) { return 0.0; });
    ins.solve(tissue);
    prev = d;
    const std::vector<double> f = tissue.solve(ins.state().axial);
    double total = 0.0;
    for (std::size_t j : ins.state().active) {
      EXPECT_LE(std::abs(f[j]), ins.state().carried[j] * (1.0 + 1e-9)) << "step " << k << " station " << j;
      total += f[j];
    }
    EXPECT_GE(total, total_prev * (1.0 - 1e-12)) << "step " << k;
    total_prev = total;
  }
  EXPECT_GT(total_prev, 0.0);
}

// The tip bearing on springs: tip rows every 0.5 from the entry, k = 4 each, F_c = 2, steps of 0.5.
// Pushing: w = cut, force 4·cut ≤ 2 up to cut = 0.5; from cut = 1 on the row is held at F_c with
// w = 0.5 and the front is cut − 0.5; the stations carry [b, min(e, cut − 0.5)] from the puncture
// step (cut = 1) on.
// (The rows' positions do not enter: the springs have no geometry.)
TEST(Insertion, TipPressesUntilTheCuttingForceThenCutsAtIt) {
  NeedleOptions<3> o = options_for("stick", 20, 0.0);
  o.friction.cutting_force = 2.0;
  std::vector<ShaftPoint<3>> tips;
  for (int k = 0; k <= 20; ++k) tips.push_back({Vec<3>(0.0, 0.0, 0.5 * k), 0.5 * k, 0.0});
  Insertion<3> ins(o, five_stations(), tips);
  ASSERT_EQ(ins.n_points(), 26u);
  Springs tissue(std::vector<double>(26, 4.0), ins.state());
  double prev = 0.0;
  for (int k = 1; k <= 20; ++k) {
    const double d = ins.depth(k);
    ins.pick_up(d, d - prev, [](std::size_t) { return 0.0; });
    ins.solve(tissue);
    prev = d;
    const ShaftState& s = ins.state();
    ASSERT_GE(s.cutting, 5u) << "step " << k;
    const double tip_force = 4.0 * s.axial[s.cutting];
    EXPECT_NEAR(tip_force, std::min(4.0 * d, 2.0), 1e-9) << "step " << k;
    EXPECT_EQ(s.tip_cutting, d > 0.5 + 1e-9) << "step " << k;
    const double front = d > 0.5 + 1e-9 ? d - 0.5 : 0.0;
    EXPECT_NEAR(s.front, front, 1e-9) << "step " << k;
    // The stations carry the tissue the tip has cut, cut − 0.5, also at the puncture step (the tissue
    // cut in that step joins after the tip row gave way, and the step is solved again).
    const double reach = front;
    for (std::size_t j = 0; j < 5; ++j) {
      const double b = 2.0 * static_cast<double>(j);
      EXPECT_NEAR(s.carried[j], std::clamp(reach - b, 0.0, 2.0), 1e-9) << "step " << k << " station " << j;
    }
  }
}

// A cutting force that rises along the path (PathProfile: F_c = 2 before s = 3.2, 6 after), tip rows on
// springs k = 4, steps of 1. Up to cut = 3 the tip cuts at 2 with the indentation 0.5 (front cut − 0.5).
// At cut = 4 it would cut to 3.5 at F_c = 2, but the tissue from 3.2 on needs 6: it cuts to 3.2 and
// presses the next tissue by 4 − 3.2 = 0.8 (force 3.2 < 6, no cut). From cut = 5 on it cuts at 6
// (indentation 1.5, front cut − 1.5). The stations carry the tissue cut, [b, min(e, front)], at every
// step: none carries the harder tissue the tip has only pressed.
TEST(Insertion, TipCutsAtEachTissuesForceUpToWhereTheCuttingForceChanges) {
  NeedleOptions<3> o = options_for("stick", 10, 0.0);
  o.friction.cutting_force = 2.0;
  o.friction.cutting_profile = PathProfile({0.0, 3.2, 10.0}, {2.0, 6.0});
  std::vector<ShaftPoint<3>> tips;
  for (int k = 0; k <= 20; ++k) tips.push_back({Vec<3>(0.0, 0.0, 0.5 * k), 0.5 * k, 0.0});
  Insertion<3> ins(o, five_stations(), tips);
  Springs tissue(std::vector<double>(26, 4.0), ins.state());
  double prev = 0.0;
  for (int k = 1; k <= 10; ++k) {
    const double d = ins.depth(k);
    ins.pick_up(d, d - prev, [](std::size_t) { return 0.0; });
    ins.solve(tissue);
    prev = d;
    const ShaftState& s = ins.state();
    ASSERT_GE(s.cutting, 5u) << "step " << k;
    const double front = d <= 3.0 + 1e-9 ? d - 0.5 : d <= 4.0 + 1e-9 ? 3.2 : d - 1.5;
    const double force = d <= 3.0 + 1e-9 ? 2.0 : d <= 4.0 + 1e-9 ? 4.0 * (d - 3.2) : 6.0;
    EXPECT_NEAR(s.front, front, 1e-9) << "step " << k;
    EXPECT_NEAR(4.0 * s.axial[s.cutting], force, 1e-9) << "step " << k;
    EXPECT_EQ(s.tip_cutting, std::abs(d - 4.0) > 1e-9) << "step " << k;
    for (std::size_t j = 0; j < 5; ++j) {
      const double b = 2.0 * static_cast<double>(j);
      EXPECT_NEAR(s.carried[j], std::clamp(front - b, 0.0, 2.0), 1e-9) << "step " << k << " station " << j;
    }
  }
}

// Withdrawn stuck (stick law, no cutting distance): the tissue on the shaft moves back with the needle
// and leaves it where the tip passes back over it, so at every depth d on the way out a station
// carries [b, min(e, d)] and holds the mean over it of d − s, the same closed form as on the way in.
// Steps of 1 cut each station of length 2 back halfway before it leaves.
TEST(Insertion, WithdrawnStationsHoldTheMeanStickValueOfTheirRemainingPart) {
  Insertion<3> ins(options_for("stick", 5, 0.0), five_stations());
  Springs tissue(std::vector<double>(5, 3.0), ins.state());
  double prev = 0.0;
  for (int k = 1; k <= 5; ++k) {
    const double d = ins.depth(k);
    ins.pick_up(d, d - prev, [](std::size_t) { return 0.0; });
    ins.solve(tissue);
    prev = d;
  }
  for (int i = 1; i <= 10; ++i) {
    const double d = 10.0 - i;
    ins.withdraw(d, d - prev);
    if (!ins.state().active.empty()) ins.solve(tissue);
    prev = d;
    const ShaftState& s = ins.state();
    for (std::size_t j = 0; j < 5; ++j) {
      const double b = 2.0 * static_cast<double>(j);
      const bool on = d > b + 1e-9;
      ASSERT_EQ(std::count(s.active.begin(), s.active.end(), j) == 1, on)
          << "depth " << d << " station " << j;
      if (!on) continue;
      const double carried = std::min(2.0, d - b);
      EXPECT_NEAR(s.carried[j], carried, 1e-12) << "depth " << d << " station " << j;
      EXPECT_NEAR(s.axial[j], d - (b + 0.5 * carried), 1e-12) << "depth " << d << " station " << j;
    }
  }
  EXPECT_TRUE(ins.state().active.empty());
}

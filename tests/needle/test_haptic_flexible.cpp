// Tests for the flexible needle of vim/needle/haptic_needle.hpp (HapticNeedle::step(BasePose)):
// - against the CLI's flexible stepping (pipeline's NeedleInsertion with needle.flexible and a bevel:
//   needle::Insertion, BandCoupling behind a DeflectedCoupling, ElasticTissue's condensed rows and
//   FlexibleTissue bent to each step's depth) on one scenario — stick-slip with a cutting distance and a
//   cutting force, P2, two tissues of different modulus, a bevelled 18 G-like tube held by a template
//   before the entry — every station's force, the tip's force, the bent tip and the base's loads at every
//   step;
// - the rigid limit: with the tube's modulus × 10⁸ and the holder gripping the hub (moving with the needle,
//   its free length shrinking), the flexible needle's forces equal the rigid needle's stepped by its tip,
//   and its tip deviation vanishes;
// - a stiff tube follows its holder's sideways move and tilt as a rigid body;
// - a pose that does not fit: a holder past the entry, the wrong step for the needle's kind.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/band_coupling.hpp>
#include <vim/needle/elastic_tissue.hpp>
#include <vim/needle/flexible/deflected_coupling.hpp>
#include <vim/needle/flexible/flexible_tissue.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/insertion.hpp>

#include "../fem/box_mesh.hpp"

using namespace vim;
using namespace vim::fem;
using namespace vim::needle;

namespace haptic_flexible_test {  // named: the suite's unity batches hold other files' helpers

// 1 × 1 × 1.5 Kuhn block, bottom face held; two tissues: modulus 1 below z = 0.75, 3 above.
ElasticModel<3> layered_block(unsigned degree) {
  const auto mesh = vim::test::kuhn_box<3>({{4, 4, 6}}, {{0.0, 0.0, 0.0}}, {{1.0, 1.0, 1.5}});
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) {
    Vec<3> c = Vec<3>::Zero();
    for (int v = 0; v < 4; ++v) c += mesh.points[mesh.cells[j][v]];
    E[j] = c[2] / 4.0 > 0.75 ? 3.0 : 1.0;
  }
  ElasticModel<3> model(mesh, E, 0.45, degree);
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>(1.0, 1.0, 1.5), 2, false, 1e-9);
  model.add_dirichlet(fixed);
  return model;
}

// The condensed region: a cylinder of radius r about the block's axis (2: the whole block, for P1's wider
// default band).
Region<3> around_path(double r = 0.6) {
  return {"cylinder", [r](const Vec<3>& x) { return std::hypot(x[0] - 0.5, x[1] - 0.5) < r; }};
}

const Vec<3> kEntry(0.52, 0.47, 1.5), kAxis(0.0, 0.0, -1.0);
constexpr double kDiameter = 0.08, kInner = 0.05, kBevelAngle = 30.0;

NeedleOptions<3> needle_options(double cutting_force) {
  NeedleOptions<3> n;
  n.path.entry = kEntry, n.path.axis = kAxis, n.path.depth = 1.05;
  n.steps = 15;
  n.diameter = kDiameter;
  n.friction.law = "stick-slip";
  n.friction.max_shear_per_length = 0.01;
  n.friction.cutting_distance = 0.03;
  n.friction.cutting_force = cutting_force;
  n.friction.max_sweeps = 50;
  return n;
}

BandCoupling::Geometry band_geometry(const ElasticModel<3>& model, const NeedleOptions<3>& n) {
  BandCoupling::Geometry g;
  g.entry = kEntry, g.axis = kAxis, g.depth = n.path.depth, g.radius = 0.5 * n.diameter;
  g.element_size = path_element_size(model.locator(), kEntry, kAxis, n.path.depth);
  g.degree = model.degree(), g.spacing = 0.16;
  if (n.friction.cutting_force > 0.0) g.tip_spacing = std::min(0.5 * g.element_size, n.path.depth / n.steps);
  return g;
}

HapticNeedle::Options haptic_options(const BandCoupling::Geometry& g, const NeedleOptions<3>& n,
                                     double pitch) {
  HapticNeedle::Options o;
  o.radius = g.radius, o.element_size = g.element_size, o.spacing = pitch, o.friction = n.friction;
  o.tip_spacing = g.tip_spacing;
  o.max_stations = 12;
  return o;
}

// Truth: the CLI's flexible stepping (pipeline/src/simulation/needle_insertion.cpp: advance_one_step,
// bend() when a point is on the needle, record_flexible()) with the library's pieces. The needle is held
// by a template `free_length` before the entry; the haptic needle is given the same holder as its base
// pose (position fixed, length free_length + depth) and the bevel's side. Every station's force, the
// tip's force, the bent tip (position and deviation) and the base's force and moment equal the CLI's to
// 1e-8 of the step's largest value at every step; the run bends the needle (a deviation above 1% of
// the depth), and its tip cuts.
TEST(HapticFlexibleNeedle, ForcesTipAndBaseLoadsEqualTheCliSteppingWithABevelP2TwoTissues) {
  auto model = layered_block(2);
  const NeedleOptions<3> n = needle_options(0.03);
  const BandCoupling::Geometry g = band_geometry(model, n);
  auto owned = std::make_unique<BandCoupling>(g, model.locator(), model.youngs_modulus(),
                                              model.poisson_ratio(), std::vector<bool>{});
  const std::vector<ShaftPoint<3>> shaft = owned->stations();
  const std::vector<ShaftPoint<3>> tips = owned->tip_rows();
  ASSERT_EQ(shaft.size(), 7u);
  ASSERT_FALSE(tips.empty());
  const double pitch = shaft.front().length;
  DeflectedCoupling coupling(std::move(owned));
  Insertion<3> cli(n, shaft, tips);
  ElasticTissue<3> tissue(model, coupling, cli.state(), cli.n_points(), pitch, {}, false);
  tissue.precompute({});
  const FlexibleNeedle tube{4.0e5, kDiameter, kInner, 0.2};
  FlexibleTissue bent(tissue, coupling, cli.state(), shaft, kAxis, tube, pitch, cli.n_points(), pitch);
  const Vec<3> side(1.0, 0.0, 0.0);
  const double ratio = 1.0 / std::tan(kBevelAngle * M_PI / 180.0);

  HapticNeedle::Options o = haptic_options(g, n, pitch);
  o.flexible = FlexibleNeedle{tube.youngs_modulus, 0.0, kInner, 0.0};
  o.bevel_angle = kBevelAngle;
  HapticNeedle haptic(model, around_path(), {}, o);
  HapticNeedle::BasePose base;
  base.position = kEntry - tube.free_length * kAxis, base.direction = kAxis, base.length = tube.free_length;
  base.bevel_side = side;
  haptic.step(base);
  bool have = false, cut = false;
  double deviation = 0.0, worst_force = 0.0, worst_tip = 0.0;
  for (int k = 1; k <= n.steps; ++k) {
    const double d = cli.depth(k), prev = cli.depth(k - 1);
    cli.pick_up(d, d - prev, [&](std::size_t j) { return have ? tissue.held_axial(j, kAxis) : 0.0; });
    const ShaftState& state = cli.state();
    have = !state.active.empty();
    if (have) {
      bent.set_depth(d, -side, ratio);
      cli.solve(bent);
    } else {
      tissue.clear();
    }
    base.length = tube.free_length + d;
    const auto& s = haptic.step(base);
    const bool tip = have && state.active.back() >= shaft.size();
    ASSERT_EQ(s.stations + (tip ? 1 : 0), state.active.size()) << "step " << k;
    const auto& ref = tissue.solution().point_force;
    double fmax = 0.0;
    for (std::size_t i = 0; i < state.active.size(); ++i) fmax = std::max(fmax, ref[i].norm());
    for (std::size_t i = 0; i < s.stations; ++i) {
      EXPECT_LT((s.station_force[i] - ref[i]).norm(), 1e-8 * fmax) << "step " << k << " station " << i;
      worst_force = std::max(worst_force, (s.station_force[i] - ref[i]).norm() / fmax);
    }
    const Vec<3> tip_ref = tip ? ref[state.active.size() - 1] : Vec<3>::Zero();
    EXPECT_LE((s.tip_force - tip_ref).norm(), 1e-8 * fmax) << "step " << k;
    EXPECT_EQ(s.tip_cutting, state.tip_cutting) << "step " << k;
    cut = cut || (tip && state.tip_cutting);
    const bool on = have && bent.depth() == d;
    const Vec<3> dev = on ? bent.deflection(d) : Vec<3>::Zero();
    EXPECT_LT((s.tip - (kEntry + d * kAxis + dev)).norm(), 1e-8 * std::max(dev.norm(), 1e-6)) << "step " << k;
    EXPECT_LT((s.tip_deviation - dev).norm(), 1e-8 * std::max(dev.norm(), 1e-6)) << "step " << k;
    const Vec<3> bf = on ? bent.base_force() : Vec<3>::Zero(), bm = on ? bent.base_moment() : Vec<3>::Zero();
    EXPECT_LT((s.base_force - bf).norm(), 1e-8 * std::max(fmax, bf.norm())) << "step " << k;
    EXPECT_LT((s.base_moment - bm).norm(), 1e-8 * std::max(fmax, bm.norm())) << "step " << k;
    deviation = dev.norm();
    if (on) worst_tip = std::max(worst_tip, (s.tip_deviation - dev).norm() / dev.norm());
  }
  std::printf(
      "flexible haptic vs CLI: station forces %.2e of the step's largest, tip deviation %.2e of its "
      "norm; final deviation %.4f (%.2f%% of the depth)\n",
      worst_force, worst_tip, deviation, 100.0 * deviation / n.path.depth);
  EXPECT_GT(deviation, 0.01 * n.path.depth);
  EXPECT_TRUE(cut);
}

// Truth: the rigid needle (HapticNeedle stepped by its tip) on the same path. The flexible needle with
// the tube's modulus × 10⁸ (its 2 × 10⁴ against the tissue's 1–3: × 10⁶ still leaves a bend under the
// bevel of 1e-5 of the force) is gripped at its hub, 1.3 behind the tip (the holder moves with it, its
// free length before the entry shrinking from 1.3 to 0.25); a bevel loads its tip. Its station and tip
// forces equal the rigid needle's within 1e-5 of the largest, and its final tip deviation is below 1e-5
// of the same needle's with the real modulus.
TEST(HapticFlexibleNeedle, StiffTubeGrippedAtTheHubEqualsTheRigidNeedle) {
  auto model = layered_block(1);
  const NeedleOptions<3> n = needle_options(0.03);
  const BandCoupling::Geometry g = band_geometry(model, n);
  const double pitch = g.spacing;
  const HapticNeedle::Options rigid_options = haptic_options(g, n, pitch);
  HapticNeedle rigid(model, around_path(2.0), {}, rigid_options);
  std::vector<double> last_deviation;
  for (double scale : {1.0, 1e8}) {
    HapticNeedle::Options o = rigid_options;
    o.flexible = FlexibleNeedle{2.0e4 * scale, 0.0, kInner, 0.0};
    o.bevel_angle = kBevelAngle;
    HapticNeedle flexible(model, around_path(2.0), {}, o);
    HapticNeedle::BasePose hub;
    hub.direction = kAxis, hub.length = 1.3, hub.bevel_side = Vec<3>(0.0, 1.0, 0.0);
    double fmax = 0.0, worst = 0.0;
    for (int k = 0; k <= n.steps; ++k) {
      const Vec<3> tip = kEntry + n.path.depth * k / n.steps * kAxis;
      hub.position = tip - hub.length * kAxis;
      const auto& f = flexible.step(hub);
      if (k == n.steps) last_deviation.push_back(f.tip_deviation.norm());
      if (scale == 1.0) continue;
      const auto& r = rigid.step(tip, kAxis);
      ASSERT_EQ(f.stations, r.stations) << "step " << k;
      for (std::size_t i = 0; i < r.stations; ++i) {
        fmax = std::max(fmax, r.station_force[i].norm());
        worst = std::max(worst, (f.station_force[i] - r.station_force[i]).norm());
      }
      fmax = std::max(fmax, r.tip_force.norm());
      worst = std::max(worst, (f.tip_force - r.tip_force).norm());
    }
    if (scale > 1.0) {
      EXPECT_LT(worst, 1e-5 * fmax);
    }
  }
  EXPECT_GT(last_deviation[0], 0.0);
  EXPECT_LT(last_deviation[1], 1e-5 * last_deviation[0]);
}

// Truth: a stiff tube moves as a rigid body with its holder. The tube with the modulus × 10⁶, gripped at
// its hub 1.3 behind the tip, is inserted along the planned line; at the last call the holder moves
// sideways by δ and tilts by θ about the x axis. The tip deviates from the planned line by δ + θ × the
// needle's length from the holder (the holder's offset plus its slope carried to the tip) within 1e-3,
// and the reported tip is the straight needle's of that pose.
TEST(HapticFlexibleNeedle, StiffTubeFollowsItsHoldersOffsetAndTilt) {
  auto model = layered_block(1);
  const NeedleOptions<3> n = needle_options(0.0);
  const BandCoupling::Geometry g = band_geometry(model, n);
  HapticNeedle::Options o = haptic_options(g, n, g.spacing);
  o.flexible = FlexibleNeedle{2.0e10, 0.0, kInner, 0.0};
  HapticNeedle needle(model, around_path(2.0), {}, o);
  HapticNeedle::BasePose hub;
  hub.direction = kAxis, hub.length = 1.3;
  for (int k = 0; k < n.steps; ++k) {
    hub.position = kEntry + (n.path.depth * k / n.steps - hub.length) * kAxis;
    needle.step(hub);
  }
  const double delta = 0.01, theta = 0.005;
  hub.position += delta * Vec<3>::UnitX();
  hub.direction = kAxis + theta * Vec<3>::UnitY();
  const auto& s = needle.step(hub);
  ASSERT_GT(s.stations, 3u);
  const double reach = hub.length / hub.direction.norm();  // the holder to the tip along the planned line
  const Vec<3> expected = delta * Vec<3>::UnitX() + theta * reach * Vec<3>::UnitY();
  EXPECT_LT((s.tip_deviation - expected).norm(), 1e-3 * expected.norm());
  EXPECT_LT((s.tip - (hub.position + hub.length * hub.direction.normalized())).norm(),
            1e-3 * expected.norm());
  EXPECT_NEAR(s.tip_angle, std::atan(theta) * 180.0 / M_PI, 1e-3 * std::atan(theta) * 180.0 / M_PI);
}

TEST(HapticFlexibleNeedle, RefusesAPoseThatDoesNotFit) {
  auto model = layered_block(1);
  const NeedleOptions<3> n = needle_options(0.0);
  const BandCoupling::Geometry g = band_geometry(model, n);
  HapticNeedle::Options o = haptic_options(g, n, g.spacing);
  HapticNeedle rigid(model, around_path(2.0), {}, o);
  HapticNeedle::BasePose base;
  base.position = kEntry, base.direction = kAxis, base.length = 0.0;
  EXPECT_THROW(rigid.step(base), std::logic_error);
  o.flexible = FlexibleNeedle{2.0e4, 0.0, kInner, 0.0};
  HapticNeedle flexible(model, around_path(2.0), {}, o);
  EXPECT_THROW(flexible.step(kEntry, kAxis), std::logic_error);
  flexible.step(base);
  base.position = kEntry + 0.1 * kAxis;  // the holder past the entry
  EXPECT_THROW(flexible.step(base), std::invalid_argument);
  o.flexible->inner_diameter = kDiameter;
  EXPECT_THROW(HapticNeedle(model, around_path(2.0), {}, o), std::invalid_argument);
}

}  // namespace haptic_flexible_test

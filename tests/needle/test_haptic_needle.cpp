// Tests for vim/needle/haptic_needle.hpp (a needle at haptic rate in a condensed region):
// - against the monolithic saddle-point solve [K Cᵀ; C −κ] (ElasticModel::solve_monolithic, UMFPACK) of
//   the same band constraints at every step — station forces and probe displacements — with stick and
//   stick-slip friction, P1 and P2, a pose that turns mid-way; sliding stations carry exactly their
//   limit, max_shear_per_length × the shaft length they carry;
//   and with a cutting force (the tip's disk row, axial only, among the rows);
// - against the CLI's stepping (pipeline's NeedleInsertion: needle::Insertion, BandCoupling with the
//   default band and its tip rows, ElasticTissue's condensed rows and the registered law) on one scenario
//   — stick-slip with a cutting distance, P2, two tissues of different modulus, without and with a
//   cutting force — station by station and in the tip's force at every step;
// - stepping allocates no memory after the first step (a counting operator new), with and without a
//   cutting force.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/band_coupling.hpp>
#include <vim/needle/elastic_tissue.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/insertion.hpp>

#include "../fem/box_mesh.hpp"

namespace {
std::atomic<long> g_allocations{0};
std::atomic<bool> g_counting{false};
}  // namespace

void* operator new(std::size_t n) {
  if (g_counting) ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
// The nothrow forms too, so every scalar new and delete of the process pairs malloc with free (a library
// that allocates with the nothrow new, as FreeImage does at load, frees through the delete above).
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  if (g_counting) ++g_allocations;
  return std::malloc(n ? n : 1);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }

using namespace vim;
using namespace vim::fem;
using namespace vim::needle;

namespace {

// 1 × 1 × 1.5 Kuhn block, bottom face held; modulus graded across (or, `layered`, two tissues: 1 below
// z = 0.75, 3 above); a body force unless `layered`.
ElasticModel<3> block(unsigned degree, bool layered = false) {
  const auto mesh = vim::test::kuhn_box<3>({{4, 4, 6}}, {{0.0, 0.0, 0.0}}, {{1.0, 1.0, 1.5}});
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) {
    Vec<3> c = Vec<3>::Zero();
    for (int v = 0; v < 4; ++v) c += mesh.points[mesh.cells[j][v]];
    E[j] = layered ? (c[2] / 4.0 > 0.75 ? 3.0 : 1.0) : 1.0 + 2.0 * mesh.points[mesh.cells[j][0]][0];
  }
  ElasticModel<3> model(mesh, E, 0.45, degree);
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>(1.0, 1.0, 1.5), 2, false, 1e-9);
  model.add_dirichlet(fixed);
  if (!layered) model.set_body_force(Vec<3>(0.0, 0.0, -0.05));
  return model;
}

Region<3> around_path() {
  return {"cylinder", [](const Vec<3>& x) { return std::hypot(x[0] - 0.5, x[1] - 0.5) < 0.6; }};
}

// The needle enters the top face at (0.52, 0.47) going down, then turns slightly mid-way.
void pose(int k, Vec<3>& tip, Vec<3>& dir) {
  dir = k < 8 ? Vec<3>(0.0, 0.0, -1.0) : Vec<3>(0.08, -0.05, -1.0).normalized();
  tip = Vec<3>(0.52, 0.47, 1.5) + 0.07 * std::min(k, 8) * Vec<3>(0.0, 0.0, -1.0) +
        0.07 * std::max(k - 8, 0) * dir;
}

HapticNeedle::Options options(double max_shear, double cutting_force = 0.0) {
  HapticNeedle::Options o;
  o.radius = 0.04, o.coupling_radius = 0.12, o.spacing = 0.15;
  o.friction.law = std::isfinite(max_shear) ? "stick-slip" : "stick";
  o.friction.max_shear_per_length = max_shear;
  o.friction.cutting_force = cutting_force;
  o.friction.max_sweeps = 20;
  o.element_size = 0.25;  // the tip disks' sample spacing
  return o;
}

void haptic_vs_monolithic(unsigned degree, double max_shear, bool expect_sliding,
                          double cutting_force = 0.0) {
  auto model = block(degree);
  const HapticNeedle::Options o = options(max_shear, cutting_force);
  const std::vector<Vec<3>> probes = {Vec<3>(0.3, 0.6, 0.9), Vec<3>(0.5, 0.5, 0.2)};
  HapticNeedle needle(model, around_path(), probes, o);
  EXPECT_LT(needle.region_dofs(), model.n_dofs());
  bool slid = false, cut = false;
  for (int k = 0; k <= 14; ++k) {
    Vec<3> tip, dir;
    pose(k, tip, dir);
    const auto& s = needle.step(tip, dir);
    EXPECT_TRUE(s.settled) << "step " << k;
    if (s.stations == 0 || (degree == 2 && k % 3 != 0)) continue;  // P2: every third step (UMFPACK's cost)
    if (cutting_force > 0.0) {                                     // the tip's disk is the last row
      const auto rows = needle.constraints();
      ASSERT_EQ(rows.size(), s.stations + 1) << "step " << k;
      const Vec<3> ref = model.solve_monolithic(rows).point_force.back();
      EXPECT_LT((s.tip_force - ref).norm(), 1e-8 * ref.norm()) << "step " << k;
      EXPECT_LE(std::abs(s.tip_force.dot(dir)), cutting_force * (1.0 + 1e-9)) << "step " << k;
      cut = cut || s.tip_cutting;
    }
    const auto rows = needle.constraints();
    const auto ref = model.solve_monolithic(rows);
    double fmax = 0.0, umax = 0.0;
    for (const auto& f : ref.point_force) fmax = std::max(fmax, f.norm());
    for (const auto& u : ref.vertex_displacement) umax = std::max(umax, u.norm());
    ASSERT_GT(fmax, 0.0);
    const ShaftState& state = needle.state();
    for (std::size_t i = 0; i < s.stations; ++i) {
      EXPECT_LT((s.station_force[i] - ref.point_force[i]).norm(), 1e-8 * fmax)
          << "step " << k << " station " << i;
      const double limit = max_shear * state.carried[state.active[i]];
      const double axial = std::abs(s.station_force[i].dot(dir));
      EXPECT_LE(axial, limit * (1.0 + 1e-9)) << "step " << k << " station " << i;
      slid = slid || (std::isfinite(limit) && std::abs(axial - limit) <= 1e-9 * limit);
    }
    const auto at = model.sample(probes);
    for (std::size_t p = 0; p < probes.size(); ++p)
      EXPECT_LT((s.probe_displacement[p] - at[p]).norm(), 1e-8 * umax) << "step " << k << " probe " << p;
  }
  EXPECT_EQ(slid, expect_sliding);
  EXPECT_EQ(cut, cutting_force > 0.0);
}

}  // namespace

TEST(HapticNeedle, StickMatchesMonolithicP1) {
  haptic_vs_monolithic(1, std::numeric_limits<double>::infinity(), false);
}
TEST(HapticNeedle, StickMatchesMonolithicP2) {
  haptic_vs_monolithic(2, std::numeric_limits<double>::infinity(), false);
}
TEST(HapticNeedle, StickSlipMatchesMonolithicP1) { haptic_vs_monolithic(1, 0.02, true); }
TEST(HapticNeedle, StickSlipMatchesMonolithicP2) { haptic_vs_monolithic(2, 0.02, true); }
TEST(HapticNeedle, TipBearingMatchesMonolithicP1) { haptic_vs_monolithic(1, 0.02, true, 0.01); }

namespace {

// Truth: the CLI's stepping of the same needle (pipeline/src/simulation/needle_insertion.cpp, its
// advance_one_step with the library's pieces): stick-slip with a cutting distance, P2, the two-tissue
// block, a straight insertion of 1.05 in 15 steps; with a cutting force the CLI's coupling has its tip
// rows (disks every min(h/2, depth/steps), as make_coupling builds them) and the haptic needle the same
// disk spacing. The haptic needle is given the CLI's station length and element size (the default band);
// every station's force and the tip's force equal the CLI's to 1e-8 of the step's largest force at every
// step, and the run exercises the law: stations slide at their limit; with a cutting force the tip
// presses the face, punctures it and then cuts at the cutting force.
void haptic_vs_cli(double cutting_force) {
  auto model = block(2, true);
  const Vec<3> entry(0.52, 0.47, 1.5), axis(0.0, 0.0, -1.0);
  NeedleOptions<3> n;
  n.path.entry = entry, n.path.axis = axis, n.path.depth = 1.05;
  n.steps = 15;
  n.diameter = 0.08;
  n.friction.law = "stick-slip";
  n.friction.max_shear_per_length = 0.01;
  n.friction.cutting_distance = 0.03;
  n.friction.cutting_force = cutting_force;
  n.friction.max_sweeps = 50;
  BandCoupling::Geometry g;
  g.entry = entry, g.axis = axis, g.depth = n.path.depth, g.radius = 0.5 * n.diameter;
  g.element_size = path_element_size(model.locator(), entry, axis, n.path.depth);
  g.degree = 2, g.spacing = 0.16;
  if (cutting_force > 0.0) g.tip_spacing = std::min(0.5 * g.element_size, n.path.depth / n.steps);
  BandCoupling band(g, model.locator(), model.youngs_modulus(), model.poisson_ratio(), {});
  const std::size_t np = band.stations().size();
  ASSERT_EQ(np, 7u);
  ASSERT_EQ(band.tip_rows().empty(), cutting_force == 0.0);
  const double pitch = band.stations().front().length;
  Insertion<3> cli(n, band.stations(), band.tip_rows());
  ElasticTissue<3> tissue(model, band, cli.state(), cli.n_points(), pitch, {}, false);
  tissue.precompute({});

  HapticNeedle::Options o;
  o.radius = g.radius, o.element_size = g.element_size, o.spacing = pitch, o.friction = n.friction;
  o.tip_spacing = g.tip_spacing;
  o.max_stations = 12;
  HapticNeedle haptic(model, around_path(), {}, o);
  haptic.step(entry, axis);
  bool have = false, slid = false, pressed = false, cut = false;
  for (int k = 1; k <= n.steps; ++k) {
    const double d = cli.depth(k), prev = cli.depth(k - 1);
    cli.pick_up(d, d - prev, [&](std::size_t j) { return have ? tissue.held_axial(j, axis) : 0.0; });
    const ShaftState& state = cli.state();
    have = !state.active.empty();
    if (have)
      cli.solve(tissue);
    else
      tissue.clear();
    const auto& s = haptic.step(entry + d * axis, axis);
    const bool tip = have && state.active.back() >= np;  // the CLI's tip presses a disk
    ASSERT_EQ(s.stations + (tip ? 1 : 0), state.active.size()) << "step " << k;
    const auto& ref = tissue.solution().point_force;
    double fmax = 0.0;
    for (std::size_t i = 0; i < state.active.size(); ++i) fmax = std::max(fmax, ref[i].norm());
    for (std::size_t i = 0; i < s.stations; ++i) {
      EXPECT_LT((s.station_force[i] - ref[i]).norm(), 1e-8 * fmax) << "step " << k << " station " << i;
      const std::size_t j = state.active[i];
      const double axial = ref[i].dot(axis);
      slid = slid || std::abs(std::abs(axial) - n.friction.max_shear_per_length * state.carried[j]) <=
                         1e-9 * n.friction.max_shear_per_length * state.carried[j];
    }
    const Vec<3> tip_ref = tip ? ref[state.active.size() - 1] : Vec<3>::Zero();
    EXPECT_LE((s.tip_force - tip_ref).norm(), 1e-8 * fmax) << "step " << k;
    EXPECT_EQ(s.tip_cutting, state.tip_cutting) << "step " << k;
    if (tip && !state.tip_cutting) pressed = pressed || (!cut && tip_ref.dot(axis) > 0.0);
    if (tip && state.tip_cutting) {
      cut = true;
      EXPECT_NEAR(tip_ref.dot(axis), cutting_force, 1e-9 * cutting_force) << "step " << k;
    }
  }
  EXPECT_TRUE(slid);
  EXPECT_EQ(pressed, cutting_force > 0.0);
  EXPECT_EQ(cut, cutting_force > 0.0);
}

}  // namespace

TEST(HapticNeedle, StationForcesEqualTheCliSteppingP2TwoTissues) { haptic_vs_cli(0.0); }
TEST(HapticNeedle, StationAndTipForcesEqualTheCliSteppingWithACuttingForceP2TwoTissues) {
  haptic_vs_cli(0.03);
}

namespace {

// Truth: a counting operator new. After the first step a step allocates nothing, stations joining
// included, with stick-slip sweeps, and with a cutting force the tip's disks being formed.
void allocations_after_warm_up(double cutting_force) {
  auto model = block(1);
  HapticNeedle needle(model, around_path(), {Vec<3>(0.3, 0.6, 0.9)}, options(0.02, cutting_force));
  Vec<3> tip, dir;
  pose(0, tip, dir);
  needle.step(tip, dir);
  g_allocations = 0;
  g_counting = true;
  int stations = 0, sweeps = 0;
  bool cut = false;
  for (int k = 1; k <= 14; ++k) {
    pose(k, tip, dir);
    const auto& s = needle.step(tip, dir);
    stations = static_cast<int>(s.stations), sweeps = std::max(sweeps, s.sweeps), cut = cut || s.tip_cutting;
  }
  g_counting = false;
  EXPECT_GT(stations, 5);
  EXPECT_GT(sweeps, 1);
  EXPECT_EQ(cut, cutting_force > 0.0);
  EXPECT_EQ(g_allocations.load(), 0);
}

}  // namespace

TEST(HapticNeedle, SteppingAllocatesNothingAfterWarmUp) { allocations_after_warm_up(0.0); }
TEST(HapticNeedle, SteppingWithACuttingForceAllocatesNothingAfterWarmUp) { allocations_after_warm_up(0.01); }

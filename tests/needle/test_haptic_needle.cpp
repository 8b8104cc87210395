// Tests for vim/needle/haptic_needle.hpp (a needle at haptic rate in a condensed region) against the
// monolithic saddle-point solve [K Cᵀ; C −κ] (ElasticModel::solve_monolithic, UMFPACK) of the same band
// constraints at every step — station forces and probe displacements — with stick and stick-slip
// friction, P1 and P2, a pose that turns mid-way; the friction limit (sliding stations carry exactly
// their limit); and that stepping allocates no memory after the first steps (a counting operator new).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/haptic_needle.hpp>

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

// 1 × 1 × 1.5 Kuhn block, graded modulus, bottom face held, a body force.
ElasticModel<3> block(unsigned degree) {
  const auto mesh = test::kuhn_box<3>({{4, 4, 6}}, {{0.0, 0.0, 0.0}}, {{1.0, 1.0, 1.5}});
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = 1.0 + 2.0 * mesh.points[mesh.cells[j][0]][0];
  ElasticModel<3> model(mesh, E, 0.45, degree);
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>(1.0, 1.0, 1.5), 2, false, 1e-9);
  model.add_dirichlet(fixed);
  model.set_body_force(Vec<3>(0.0, 0.0, -0.05));
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

void haptic_vs_monolithic(unsigned degree, double max_shear, bool expect_sliding) {
  auto model = block(degree);
  HapticNeedle::Options o;
  o.radius = 0.04, o.coupling_radius = 0.12, o.spacing = 0.15, o.max_shear_per_length = max_shear;
  o.max_sweeps = 20;
  const std::vector<Vec<3>> probes = {Vec<3>(0.3, 0.6, 0.9), Vec<3>(0.5, 0.5, 0.2)};
  HapticNeedle needle(model, around_path(), probes, o);
  EXPECT_LT(needle.region_dofs(), model.n_dofs());
  bool slid = false;
  for (int k = 0; k <= 14; ++k) {
    Vec<3> tip, dir;
    pose(k, tip, dir);
    const auto& s = needle.step(tip, dir);
    EXPECT_TRUE(s.settled) << "step " << k;
    if (s.stations == 0 || (degree == 2 && k % 3 != 0)) continue;  // P2: every third step (UMFPACK's cost)
    const auto rows = needle.constraints();
    const auto ref = model.solve_monolithic(rows);
    double fmax = 0.0, umax = 0.0;
    for (const auto& f : ref.point_force) fmax = std::max(fmax, f.norm());
    for (const auto& u : ref.vertex_displacement) umax = std::max(umax, u.norm());
    ASSERT_GT(fmax, 0.0);
    for (std::size_t j = 0; j < s.stations; ++j) {
      EXPECT_LT((s.station_force[j] - ref.point_force[j]).norm(), 1e-8 * fmax)
          << "step " << k << " station " << j;
      if (s.sliding[j]) {
        slid = true;
        EXPECT_NEAR(std::abs(s.station_force[j].dot(dir)), max_shear * o.spacing,
                    1e-9 * max_shear * o.spacing);
      }
    }
    const auto at = model.sample(probes);
    for (std::size_t p = 0; p < probes.size(); ++p)
      EXPECT_LT((s.probe_displacement[p] - at[p]).norm(), 1e-8 * umax) << "step " << k << " probe " << p;
  }
  EXPECT_EQ(slid, expect_sliding);
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

// Truth: a counting operator new. After the first steps (the result vectors sized) a step allocates
// nothing, stations joining included, with stick-slip sweeps.
TEST(HapticNeedle, SteppingAllocatesNothingAfterWarmUp) {
  auto model = block(1);
  HapticNeedle::Options o;
  o.radius = 0.04, o.coupling_radius = 0.12, o.spacing = 0.15, o.max_shear_per_length = 0.02;
  HapticNeedle needle(model, around_path(), {Vec<3>(0.3, 0.6, 0.9)}, o);
  Vec<3> tip, dir;
  pose(0, tip, dir);
  needle.step(tip, dir);
  g_allocations = 0;
  g_counting = true;
  int stations = 0;
  for (int k = 1; k <= 14; ++k) {
    pose(k, tip, dir);
    stations = static_cast<int>(needle.step(tip, dir).stations);
  }
  g_counting = false;
  EXPECT_GT(stations, 5);
  EXPECT_EQ(g_allocations.load(), 0);
}

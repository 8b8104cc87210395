// needle.tissues: the friction limit and cutting force of the tissue the path crosses (a scenario
// region or a modulus range), against closed forms: the sliding force is the integral of q_tissue over
// the carried shaft, and a stiff layer with a higher cutting force is pushed until
// its cutting force, then cut (a puncture peak and drop at the interface).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// Carried length of each shaft point at needle travel d (3D stations: each passed station its band,
// the last one whose band the tip has entered everything up to the tip).
// The shaft length each station carries at needle depth d where the tip has certainly passed its whole
// band (the band ends a band length or more behind the needle's end, and the tissue at the tip is
// pushed less than that): its whole band length; -1 for the stations near the tip, whose cut part
// depends on how far the tip pushed the tissue ahead of it.
std::vector<double> carried_lengths(const NeedleRun<3>& r, double d) {
  std::vector<double> carried(r.point_s.size(), -1.0);
  for (std::size_t j = 0; j < r.point_s.size(); ++j)
    if (r.point_s[j] + 1.5 * r.point_length[j] <= d) carried[j] = r.point_length[j];
  return carried;
}

// ∫_a^b q ds for q = q_soft below z_layer and q_deep from it on (the path runs along z from 0).
double two_layer_integral(double a, double b, double q_soft, double q_deep, double z_layer) {
  return q_soft * (std::min(b, z_layer) - std::min(a, z_layer)) +
         q_deep * (std::max(b, z_layer) - std::max(a, z_layer));
}

}  // namespace

// Two layers (z < 8: the needle's own q = 0.05; z >= 8: q = 0.4 from a box region, the first entry; a
// second entry that holds the deepest of them is ignored there). The friction is low enough that every
// station slides at the last step: each station's force is the integral of q over the shaft it carries
// (a station across z = 8 takes each layer's q for its own part, not the q at its centre), so the
// shaft behind the last wholly carried station pulls exactly q_soft·8 + q_deep·(e − 8), e that
// station's end, whatever the stations' layout (with one q for all, the deep part would be 8 times too
// small; with q sampled at each station's centre, the station across z = 8 would be off by
// (q_deep − q_soft) × the distance from its centre to z = 8).
TEST(NeedleTissues, SlidingForceIsTheIntegralOfEachTissuesLimitAlongTheCarriedShaft) {
  const double q_soft = 0.05, q_deep = 0.4, z_layer = 8.0;
  for (const char* spacing :
       {", sample_spacing: 3", ", sample_spacing: 2.5"}) {  // across z = 8: [6, 9], [7.5, 10]
    SCOPED_TRACE(spacing);
    const std::string needle =
        std::string("{entry: [0, 0, 0], direction: [0, 0, 1], depth: 20, steps: 10, diameter: 1") + spacing +
        ", friction: {model: stick-slip, max_shear_per_length: 0.05}, tissues: [{region: {box: {min: [-7, "
        "-7, "
        "8], max: [7, 7, 25]}}, max_shear_per_length: 0.4}, {region: {box: {min: [-7, -7, 12], max: [7, 7, "
        "25]}}, max_shear_per_length: 9}]}";
    const auto res = run_simulation<3>(axis_block(), parse_scenario_text(yaml(needle), 3), quiet());
    const NeedleRun<3>& r = res.needles[0];
    ASSERT_EQ(r.point_tissue.size(), r.point_s.size());
    int across = 0;
    for (std::size_t j = 0; j < r.point_s.size(); ++j) {
      EXPECT_EQ(r.point_tissue[j], r.point_s[j] >= z_layer ? 0 : -1) << "station at s = " << r.point_s[j];
      const double b = r.point_s[j] - 0.5 * r.point_length[j], e = b + r.point_length[j];
      across += b < z_layer - 0.1 && e > z_layer + 0.1;
    }
    ASSERT_EQ(across, 1);
    const double d = r.depth.back();
    const std::vector<double> carried = carried_lengths(r, d);
    double sum = 0.0, rest = 0.0, end = 0.0;
    for (std::size_t j = 0; j < carried.size(); ++j) {
      const double b = r.point_s[j] - 0.5 * r.point_length[j], e = b + r.point_length[j];
      const double f = std::abs(r.point_axial_force.back()[j]);
      const double limit = two_layer_integral(b, e, q_soft, q_deep, z_layer);
      if (carried[j] < 0.0) {  // near the tip: within its limit for the part it can carry
        EXPECT_LE(f, limit * (1.0 + 1e-9)) << "station " << j;
        rest += f;
        continue;
      }
      EXPECT_NEAR(f, limit, 1e-9 * limit) << "station " << j;
      sum += f;
      end = std::max(end, e);
    }
    ASSERT_GT(end, z_layer + 3.0);
    // The wholly carried shaft [0, end]: the integral from the region boundary, by hand.
    const double exact = q_soft * z_layer + q_deep * (end - z_layer);
    EXPECT_NEAR(sum, exact, 1e-9 * exact);
    EXPECT_NEAR(r.axial_force.back(), sum + rest, 1e-9 * (sum + rest));
  }
}

// A stiff layer (E 40 for 10 < z < 14, a capsule picked by a modulus range) whose cutting force 3 is
// far above the soft tissue's (0.3): the tip pushes the stiff tissue until its force reaches 3 (the
// tip force equals it while it is held), and once through the layer the axial force drops. The same
// needle without the tissue entry has no such peak.
TEST(NeedleTissues, StiffLayerWithAHigherCuttingForceGivesAPuncturePeakAndDrop) {
  const double fc_stiff = 3.0;
  const auto model = [] {
    MeshModel<3> m = axis_block();
    for (std::size_t c = 0; c < m.mesh.n_cells(); ++c)
      m.values[c].mean = std::abs(centroid<3>(cell_points(m.mesh, c))[2] - 12.0) < 2.0 ? 40.0 : 10.0;
    return m;
  }();
  const std::string base =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 20, steps: 40, diameter: 1, cutting_force: 0.3, "
      "friction: {model: stick-slip, max_shear_per_length: 0.05}";
  const auto with = run_simulation<3>(
      model,
      parse_scenario_text(
          yaml(base + ", tissues: [{region: {modulus: {min: 30, max: 50}}, cutting_force: 3}]}"), 3),
      quiet());
  const auto without = run_simulation<3>(model, parse_scenario_text(yaml(base + "}"), 3), quiet());
  const NeedleRun<3>& r = with.needles[0];
  // The tip force reaches the stiff layer's cutting force (never more), then drops once the layer is cut.
  std::size_t peak = 0;
  for (std::size_t k = 1; k < r.tip_force.size(); ++k) {
    EXPECT_LE(r.tip_force[k], fc_stiff * (1 + 1e-6)) << "step " << k;
    if (r.tip_force[k] > r.tip_force[peak]) peak = k;
  }
  EXPECT_NEAR(r.tip_force[peak], fc_stiff, 1e-6 * fc_stiff);
  EXPECT_GE(r.depth[peak], 10.0 - 2.0);
  EXPECT_LE(r.depth[peak], 14.0 + 2.0);
  bool drop = false;
  for (std::size_t k = peak + 1; k < r.axial_force.size(); ++k)
    drop = drop || r.axial_force[k] < r.axial_force[peak] - 0.5 * fc_stiff;
  EXPECT_TRUE(drop);
  double max_without = 0.0;
  for (double f : without.needles[0].tip_force) max_without = std::max(max_without, f);
  EXPECT_LE(max_without, 0.3 * (1 + 1e-6));
}

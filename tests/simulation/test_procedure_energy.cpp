// The energy balance of a needle in and out (docs/procedure.md, "Energy"): the work the needle does on the
// tissue is stored as strain energy or dissipated by friction (force × slip). Truth: the strain energy
// ½ uᵀKu of each step's field, computed here by a model built from the fem API (not by the run), so that
// at every step the run's dissipated work equals its needle work minus the stored energy's change. With
// stick-slip friction the tissue slips along the shaft, the dissipated work is positive, and once the
// needle is out (the tissue at rest) all the needle's work has been dissipated.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// The needle on the axis of the test block (E = 10 kPa, ν = 0.49, P1, face z = 24 fixed), 12 mm in 6
// steps and out in 6; friction `friction`.
std::string in_and_out(const std::string& friction) {
  return "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
         "procedure:\n"
         "  - insert: {name: a, entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
         "friction: " +
         friction +
         "}\n"
         "  - withdraw: {needle: a, steps: 6}\n";
}

struct Balance {
  std::vector<double> stored;  // ½ uᵀKu per step
  NeedleRun<3> run;
  nlohmann::json report;
};

Balance run_balance(const std::string& friction) {
  const MeshModel<3> mm = axis_block();
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  SimulationResult<3> res =
      run_simulation<3>(mm, parse_scenario_text(in_and_out(friction), 3, "plan.yaml"), o);
  const fem::ElasticModel<3> model(mm.mesh, std::vector<double>(mm.mesh.n_cells(), 10.0), 0.49, 1);
  Balance b;
  b.run = std::move(res.needles.at(0));
  b.report = res.report["needles"][0]["energy"];
  for (const auto& u : b.run.vertex_displacement) b.stored.push_back(model.strain_energy_of(u));
  return b;
}

}  // namespace

TEST(ProcedureEnergy, DissipatedWorkIsTheNeedlesWorkLessTheStoredEnergy) {
  const Balance b = run_balance("{model: stick-slip, max_shear_per_length: 0.5}");
  const NeedleRun<3>& r = b.run;
  ASSERT_EQ(r.depth.size(), 13u);
  ASSERT_EQ(r.needle_work.size(), 13u);
  ASSERT_EQ(r.dissipated_work.size(), 13u);
  ASSERT_EQ(b.stored.size(), 13u);
  const double scale = *std::max_element(r.needle_work.begin(), r.needle_work.end());
  ASSERT_GT(scale, 1e-3);  // mN·mm
  double largest_stored = 0.0;
  for (std::size_t k = 0; k < 13; ++k) {
    const double balance = r.needle_work[k] - (b.stored[k] - b.stored[0]);
    EXPECT_NEAR(r.dissipated_work[k], balance, 1e-6 * scale) << "step " << k;
    if (k > 0) {
      EXPECT_GE(r.dissipated_work[k] - r.dissipated_work[k - 1], -1e-9 * scale) << "step " << k;
    }
    largest_stored = std::max(largest_stored, b.stored[k]);
  }
  EXPECT_GT(largest_stored, 1e-3 * scale);                  // energy is stored while the needle is in
  EXPECT_GT(r.dissipated_work[6], 0.1 * r.needle_work[6]);  // the tissue slips on the way in
  // Out again, the tissue at rest: the needle's work has all been dissipated.
  EXPECT_LT(b.stored.back(), 1e-12 * scale);
  EXPECT_NEAR(r.dissipated_work.back(), r.needle_work.back(), 1e-6 * scale);
  EXPECT_GT(r.dissipated_work.back(), 0.0);
  EXPECT_EQ(b.report["needle_work"].get<double>(), r.needle_work.back());
  EXPECT_EQ(b.report["dissipated_work"].get<double>(), r.dissipated_work.back());
}

// A needle that sticks: the balance holds as well (the work on the tissue is the stored energy's change),
// and it dissipates less than one that slips at a low limit.
TEST(ProcedureEnergy, StuckNeedleBalancesAndDissipatesLessThanASlippingOne) {
  const Balance stuck = run_balance("{model: stick}");
  const Balance slips = run_balance("{model: stick-slip, max_shear_per_length: 0.5}");
  const NeedleRun<3>& r = stuck.run;
  const double scale = *std::max_element(r.needle_work.begin(), r.needle_work.end());
  for (std::size_t k = 0; k < r.needle_work.size(); ++k)
    EXPECT_NEAR(r.dissipated_work[k], r.needle_work[k] - (stuck.stored[k] - stuck.stored[0]), 1e-6 * scale)
        << "step " << k;
  EXPECT_LT(std::abs(r.dissipated_work[6]), slips.run.dissipated_work[6]);
}

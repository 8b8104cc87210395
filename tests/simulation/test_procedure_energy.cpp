// The energy balance of a needle in and out (docs/procedure.md, "Energy"): the work the needle does on the
// tissue is stored or dissipated, by friction (force × slip along the shaft) or where the tissue at the tip
// joins or leaves the needle. Truths: the stored energy as a state function, ½ Σ f_j ū_j over the rows
// (Clapeyron's theorem: the rows are the only load), against the path sums of the work, so that at every
// step the dissipated work equals the needle's work less the stored energy's change; that stored energy
// holds at least the strain energy ½ uᵀKu of the mesh's field, computed here by a model built from the
// fem API (the rest is in the bands' near field); a stuck needle does not slip, so friction dissipates
// nothing; with stick-slip the tissue slips, the dissipated work grows at every step and is positive.
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

// The balance at every step: D + J = W − (E_k − E_0), E = ½ Σ f ū ≥ ½ uᵀKu.
static void expect_balance(const Balance& b, double scale) {
  const NeedleRun<3>& r = b.run;
  ASSERT_EQ(r.row_energy.size(), r.needle_work.size());
  for (std::size_t k = 0; k < r.needle_work.size(); ++k) {
    const double stored = r.row_energy[k] - r.row_energy[0];
    EXPECT_NEAR(r.dissipated_work[k] + r.join_work[k], r.needle_work[k] - stored, 1e-6 * scale)
        << "step " << k;
    EXPECT_GE(r.row_energy[k], b.stored[k] - 1e-9 * scale) << "step " << k;
  }
}

TEST(ProcedureEnergy, DissipatedWorkIsTheNeedlesWorkLessTheStoredEnergy) {
  const Balance b = run_balance("{model: stick-slip, max_shear_per_length: 0.5}");
  const NeedleRun<3>& r = b.run;
  ASSERT_EQ(r.depth.size(), 13u);
  ASSERT_EQ(r.needle_work.size(), 13u);
  ASSERT_EQ(r.dissipated_work.size(), 13u);
  ASSERT_EQ(r.join_work.size(), 13u);
  ASSERT_EQ(b.stored.size(), 13u);
  const double scale = *std::max_element(r.needle_work.begin(), r.needle_work.end());
  ASSERT_GT(scale, 1e-3);  // mN·mm
  expect_balance(b, scale);
  for (std::size_t k = 1; k < 13; ++k)  // friction × slip: the slip is along the friction force
    EXPECT_GE(r.dissipated_work[k] - r.dissipated_work[k - 1], -1e-9 * scale) << "step " << k;
  EXPECT_GT(*std::max_element(b.stored.begin(), b.stored.end()), 1e-3);  // stored while the needle is in
  EXPECT_GT(r.dissipated_work[6], 0.5 * r.needle_work[6]);               // the tissue slips on the way in
  EXPECT_GT(r.dissipated_work[12], r.dissipated_work[6]);                // and on the way out
  // Out again, the tissue at rest: the needle's work has all been dissipated or spent at the tip.
  EXPECT_LT(std::abs(r.row_energy.back()), 1e-12 * scale);
  EXPECT_LT(b.stored.back(), 1e-12 * scale);
  EXPECT_NEAR(r.dissipated_work.back() + r.join_work.back(), r.needle_work.back(), 1e-6 * scale);
  EXPECT_EQ(b.report["needle_work"].get<double>(), r.needle_work.back());
  EXPECT_EQ(b.report["dissipated_work"].get<double>(), r.dissipated_work.back());
  EXPECT_EQ(b.report["join_work"].get<double>(), r.join_work.back());
}

// A needle that sticks: its stations move with it (no slip), so friction dissipates nothing, and the
// balance holds with the joins' work alone.
TEST(ProcedureEnergy, StuckNeedleDissipatesNothingByFriction) {
  const Balance stuck = run_balance("{model: stick}");
  const NeedleRun<3>& r = stuck.run;
  const double scale = *std::max_element(r.needle_work.begin(), r.needle_work.end());
  ASSERT_GT(scale, 1e-3);
  expect_balance(stuck, scale);
  for (std::size_t k = 0; k < r.needle_work.size(); ++k)
    EXPECT_LT(std::abs(r.dissipated_work[k]), 1e-9 * scale) << "step " << k;
  EXPECT_GT(*std::max_element(stuck.stored.begin(), stuck.stored.end()), 1e-3);
}

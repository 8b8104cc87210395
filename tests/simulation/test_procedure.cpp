// A procedure (docs/procedure.md): insertions withdrawn step by step, seeds released on the way out.
// Truths: the seed rule in the linear model (a seed is the material point X = P − u(P) of the tissue at
// its planned position P at release, so once the tissue is back at rest its error is −u(P)), with u(P)
// read from a target placed at P, and the release step counted by hand from the withdrawal's depths;
// without friction the tissue never moves (seeds on plan); linear elasticity keeps no memory, so a
// stuck needle that has left the tissue leaves it at rest.
#include <gtest/gtest.h>

#include <string>
#include <vector>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// One insertion along z off the block's axis (depth 12 in 6 steps), withdrawn in `out` steps, seeds at
// 4, 8 and 12, with targets at the seeds' planned positions.
std::string procedure(const std::string& friction, int out) {
  return "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
         "procedure:\n"
         "  - insert: {name: a, entry: [0.3, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: "
         "1,\n"
         "             friction: " +
         friction +
         ", seeds: [8, 4, 12]}\n"
         "  - withdraw: {needle: a, steps: " +
         std::to_string(out) +
         "}\n"
         "targets: [{name: s4, position: [0.3, 0.2, 4]}, {name: s8, position: [0.3, 0.2, 8]},\n"
         "          {name: s12, position: [0.3, 0.2, 12]}]\n";
}

}  // namespace

TEST(Procedure, SeedErrorIsMinusTheTissueDisplacementAtItsReleasePoint) {
  const Scenario sc =
      parse_scenario_text(procedure("{model: stick-slip, max_shear_per_length: 0.5}", 6), 3, "plan.yaml");
  ASSERT_EQ(sc.needles.size(), 1u);
  ASSERT_EQ(sc.needles[0].withdraw_steps, 6);
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, o);
  const NeedleRun<3>& run = res.needles.at(0);
  ASSERT_EQ(run.depth.size(), 13u);  // rest, 6 steps in, 6 out
  EXPECT_NEAR(run.depth.back(), 0.0, 1e-12);
  // The tissue is back at rest once the needle is out.
  EXPECT_LT(max_norm(run.vertex_displacement.back()), 1e-9);
  ASSERT_EQ(run.seeds.size(), 3u);
  // Depths out: 10, 8, 6, 4, 2, 0 at steps 7..12: released at the first step at or above the seed.
  const std::vector<double> depths{4, 8, 12};
  const std::vector<int> steps{10, 8, 7};
  double largest = 0.0;
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& seed = run.seeds[i];
    EXPECT_DOUBLE_EQ(seed.depth, depths[i]);
    EXPECT_EQ(seed.release_step, steps[i]) << "seed at " << depths[i];
    EXPECT_NEAR((seed.planned - V3(0.3, 0.2, depths[i])).norm(), 0.0, 1e-12);
    const V3 u = run.target_displacement[static_cast<std::size_t>(seed.release_step)][i];
    EXPECT_LT((seed.error() + u).norm(), 1e-8) << "seed at " << depths[i];
    largest = std::max(largest, seed.error().norm());
  }
  EXPECT_GT(largest, 1e-3);  // the tissue the seeds are left in has moved
  // On the way out every station slides, friction reversed: the tissue pulls the needle inwards with the
  // limit times the shaft length still in, −0.5 · d.
  for (std::size_t k = 7; k < run.axial_force.size(); ++k)
    EXPECT_NEAR(run.axial_force[k], -0.5 * run.depth[k], 1e-6) << "step " << k;
  ASSERT_TRUE(res.report.contains("seeds"));
  const auto& all = res.report["seeds"]["all"];
  EXPECT_EQ(all["count"].get<int>(), 3);
  EXPECT_NEAR(all["max_error"].get<double>(), largest, 1e-12);
}

TEST(Procedure, WithoutFrictionSeedsLandOnPlan) {
  Scenario sc =
      parse_scenario_text(procedure("{model: stick-slip, max_shear_per_length: 0.5}", 4), 3, "plan.yaml");
  sc.needles[0].max_shear_per_length = 0.0;  // no friction (the parser asks for a limit > 0)
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, quiet());
  const NeedleRun<3>& run = res.needles.at(0);
  ASSERT_EQ(run.seeds.size(), 3u);
  for (const auto& seed : run.seeds) {
    EXPECT_GE(seed.release_step, 7);
    EXPECT_LT(seed.error().norm(), 1e-9) << "seed at " << seed.depth;
  }
}

TEST(Procedure, StuckNeedleWithdrawnLeavesTheTissueAtRest) {
  const Scenario sc = parse_scenario_text(procedure("{model: stick}", 6), 3, "plan.yaml");
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, o);
  const NeedleRun<3>& run = res.needles.at(0);
  ASSERT_EQ(run.vertex_displacement.size(), 13u);
  EXPECT_GT(max_norm(run.vertex_displacement[6]), 0.1);  // fully in: the stuck shaft drags the tissue
  EXPECT_LT(max_norm(run.vertex_displacement.back()), 1e-9);
  EXPECT_EQ(run.active_points.back(), 0);
  EXPECT_NEAR(run.axial_force.back(), 0.0, 1e-12);
  // On the way out the stations still on the shaft hold less and less: the force falls step by step.
  for (std::size_t k = 7; k < run.axial_force.size(); ++k)
    EXPECT_LT(run.axial_force[k], run.axial_force[k - 1] + 1e-9) << "step " << k;
}

TEST(Procedure, WithoutProcedureNothingIsWithdrawn) {
  const Scenario sc = parse_scenario_text(yaml(kStick), 3);
  EXPECT_FALSE(sc.procedure);
  EXPECT_EQ(sc.needles.at(0).withdraw_steps, 0);
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, quiet());
  EXPECT_EQ(res.needles.at(0).depth.size(), 7u);
  EXPECT_FALSE(res.report.contains("seeds"));
}

TEST(Procedure, BadActionsNameTheFileLineAndKey) {
  const std::string head = "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n";
  const std::string a =
      "{name: a, entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
      "friction: {model: stick}";
  std::string e = procedure_parse_error(head + "procedure:\n  - insert: " + a + ", seeds: [4, 13]}\n");
  EXPECT_NE(e.find("plan.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[0].insert.seeds[1] = 13 must be a depth in (0, 12]"), std::string::npos) << e;
  e = procedure_parse_error(head + "procedure:\n  - insert: " + a + ", seeds: [0]}\n");
  EXPECT_NE(e.find("procedure[0].insert.seeds[0] = 0"), std::string::npos) << e;
  e = procedure_parse_error(head + "procedure:\n  - insert: " + a +
                            "}\n  - withdraw: {needle: b, steps: 3}\n");
  EXPECT_NE(e.find("plan.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[1].withdraw.needle = 'b' names no needle inserted before it"),
            std::string::npos)
      << e;
  e = procedure_parse_error(head + "procedure:\n  - insert: " + a +
                            "}\n  - withdraw: {needle: a, steps: 3}\n  - withdraw: {needle: a, steps: 3}\n");
  EXPECT_NE(e.find("plan.yaml:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[2].withdraw.needle = 'a' is not in the tissue"), std::string::npos) << e;
  e = procedure_parse_error(head + "procedure:\n  - retract: {needle: a}\n");
  EXPECT_NE(e.find("unknown key 'procedure[0].retract'"), std::string::npos) << e;
}

// A needle left in (`stay: true`) and withdrawn by a later action (docs/procedure.md). Truth: linear
// elasticity holds no memory, so once the actions between have left the tissue as they found it (a needle
// in and out), the later withdrawal retraces, step by step, the withdrawal of the same needle run in and
// out at once (stick law: the state at a depth is the insertion's at that depth); with a load that stays
// (the probe moved), the tissue after the withdrawal is that of the load alone, solved without the needle.
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

const std::string kLeftInHead =
    "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n";
const std::string kNeedleA =
    "{name: a, entry: [-2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
    "friction: {model: stick}";
const std::string kNeedleB =
    "{name: b, entry: [2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
    "friction: {model: stick}";
const std::string kLeftInTargets =
    "targets: [{name: mid, position: [0, 0.2, 8]}, {name: s4, position: [2.1, 0.2, 4]},\n"
    "          {name: s8, position: [2.1, 0.2, 8]}]\n";

double largest_vertex_change(const std::vector<V3>& u, const std::vector<V3>& v) {
  double m = 0.0;
  for (std::size_t i = 0; i < u.size(); ++i) m = std::max(m, (u[i] - v[i]).norm());
  return m;
}

}  // namespace

// a left in, b in (seeds at 4 and 8) and out, then a withdrawn in 6 steps; against a alone, in and out.
TEST(ProcedureWithdrawLeftIn, LaterWithdrawalRetracesTheNeedlesOwnWithdrawal) {
  const Scenario sc = parse_scenario_text(kLeftInHead + "procedure:\n  - insert: " + kNeedleA +
                                              ", stay: true}\n  - insert: " + kNeedleB +
                                              ", seeds: [4, 8]}\n  - withdraw: {needle: b, steps: 6}\n"
                                              "  - withdraw: {needle: a, steps: 6}\n" +
                                              kLeftInTargets,
                                          3, "plan.yaml");
  ASSERT_TRUE(sc.needles.at(0).withdrawn_later());
  EXPECT_EQ(sc.needles[0].withdraw_action, 3);
  EXPECT_EQ(sc.needles[0].withdraw_after, 2u);
  const Scenario alone = parse_scenario_text(kLeftInHead + "procedure:\n  - insert: " + kNeedleA +
                                                 "}\n  - withdraw: {needle: a, steps: 6}\n" + kLeftInTargets,
                                             3, "plan.yaml");
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, o);
  const SimulationResult<3> ref = run_simulation<3>(axis_block(), alone, o);
  ASSERT_EQ(res.needles.size(), 2u);
  const NeedleRun<3>& a = res.needles[0];
  const NeedleRun<3>& a_ref = ref.needles.at(0);
  ASSERT_EQ(a.depth.size(), 13u);  // in (6), out later (6)
  ASSERT_EQ(a_ref.depth.size(), 13u);
  EXPECT_EQ(res.report["needles"][0]["name"], "a");
  for (std::size_t k = 0; k < 13; ++k) {
    EXPECT_NEAR(a.depth[k], a_ref.depth[k], 1e-12) << k;
    EXPECT_LT(largest_vertex_change(a.vertex_displacement[k], a_ref.vertex_displacement[k]), 1e-9) << k;
    EXPECT_NEAR(a.axial_force[k], a_ref.axial_force[k], 1e-9 * std::max(1.0, std::abs(a_ref.axial_force[k])))
        << k;
    for (std::size_t t = 0; t < 3; ++t)
      EXPECT_LT((a.target_displacement[k][t] - a_ref.target_displacement[k][t]).norm(), 1e-9)
          << k << " " << t;
  }
  EXPECT_GT(max_norm(a.vertex_displacement[6]), 0.1);       // the stuck needle had dragged the tissue
  EXPECT_LT(max_norm(a.vertex_displacement.back()), 1e-9);  // and the tissue is back at rest
  // b's seeds end where a's withdrawal leaves their tissue (at rest): error = −u_release(P).
  const NeedleRun<3>& b = res.needles[1];
  ASSERT_EQ(b.seeds.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& seed = b.seeds[i];
    EXPECT_LT(seed.rest_displacement.norm(), 1e-9) << "seed " << i;
    const V3 at_release = b.target_displacement.at(static_cast<std::size_t>(seed.release_step))[i + 1];
    EXPECT_GT(at_release.norm(), 1e-3) << "seed " << i;
    EXPECT_LT((seed.error() + at_release).norm(), 1e-8) << "seed " << i;
  }
  EXPECT_NEAR(res.report["seeds"]["all"]["max_error"].get<double>(),
              std::max(b.seeds[0].error().norm(), b.seeds[1].error().norm()), 1e-12);
}

// a left in, the probe moved, a withdrawn: the tissue is that of the motion alone (a scenario without a).
TEST(ProcedureWithdrawLeftIn, AfterTheProbeMotionTheTissueIsThatOfTheMotionAlone) {
  const std::string probe =
      "probe: {region: {cylinder: {center: [0, -4, 12], axis: [0, 0, 1], radius: 1.5}}, "
      "support: {elastic: {stiffness: 40, spacing: 0.5}}}\n";
  const std::string head = "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: y_max}}]\n" +
                           probe + kLeftInTargets;
  const std::string motion = "  - probe: {translate: [0, 0.2, 0.5], steps: 2}\n";
  const Scenario sc = parse_scenario_text(head + "procedure:\n  - insert: " + kNeedleA + ", stay: true}\n" +
                                              motion + "  - withdraw: {needle: a, steps: 4}\n",
                                          3, "plan.yaml");
  const Scenario without = parse_scenario_text(head + "procedure:\n" + motion, 3, "plan.yaml");
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, o);
  const SimulationResult<3> ref = run_simulation<3>(axis_block(), without, o);
  ASSERT_EQ(res.needles.size(), 1u);
  ASSERT_EQ(res.probe_steps.size(), 2u);
  ASSERT_EQ(ref.probe_steps.size(), 2u);
  const NeedleRun<3>& a = res.needles[0];
  ASSERT_EQ(a.depth.size(), 11u);  // in (6), out after the motion (4)
  EXPECT_NEAR(a.depth.back(), 0.0, 1e-12);
  for (std::size_t t = 0; t < 3; ++t) {
    const V3 motion_alone = ref.probe_steps.back().target_displacement.at(t);
    EXPECT_GT(motion_alone.norm(), 1e-4) << t;
    // While a is in, the motion moves the targets differently (a's stations hold their tissue) ...
    if (t == 0) {
      EXPECT_GT((res.probe_steps.back().target_displacement[t] - motion_alone).norm(), 1e-4);
    }
    // ... and once it is out the tissue is the motion's alone.
    EXPECT_LT((a.target_displacement.back()[t] - motion_alone).norm(), 1e-9) << t;
  }
}

TEST(ProcedureWithdrawLeftIn, BadWithdrawalsNameTheFileLineAndKey) {
  std::string e = procedure_parse_error(kLeftInHead + "procedure:\n  - insert: " + kNeedleA +
                                        ", stay: true}\n  - withdraw: {needle: a, steps: 3}\n"
                                        "  - withdraw: {needle: a, steps: 3}\n");
  EXPECT_NE(e.find("plan.yaml:6:"), std::string::npos) << e;
  EXPECT_NE(
      e.find("procedure[2].withdraw.needle = 'a' is not in the tissue (it was withdrawn before, on line 5)"),
      std::string::npos)
      << e;
  e = procedure_parse_error(kLeftInHead + "procedure:\n  - insert: " + kNeedleA +
                            ", stay: true}\n  - withdraw: {needle: a}\n");
  EXPECT_NE(e.find("procedure[1].withdraw"), std::string::npos) << e;
  EXPECT_NE(e.find("steps"), std::string::npos) << e;
}

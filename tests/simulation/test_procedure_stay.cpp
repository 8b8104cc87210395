// A needle left in (`stay: true`, docs/procedure.md): its stations keep holding the tissue where its last
// step left it while the next needle goes in and out. Truth: linear elasticity has a unique static
// solution for given held rows, so with the staying needle's rows alone (the next needle not yet in, or
// back out) the tissue is exactly where the staying needle left it; without the carry-over it would be
// at rest. The seeds of the next needle then land by the seed rule with that state as their rest state.
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

const std::string kStayHead =
    "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n";

// Needle a at x = −2.1 (stay or not), then needle b at x = +2.1 with seeds at 4 and 8, withdrawn in 6
// steps; targets between the needles and at b's seeds.
std::string two_needles(bool stay) {
  return kStayHead +
         "procedure:\n"
         "  - insert: {name: a, entry: [-2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, "
         "diameter: 1, friction: {model: stick}, stay: " +
         (stay ? "true" : "false") +
         "}\n"
         "  - insert: {name: b, entry: [2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, "
         "diameter: 1, friction: {model: stick}, seeds: [4, 8]}\n"
         "  - withdraw: {needle: b, steps: 6}\n"
         "targets: [{name: mid, position: [0, 0.2, 8]}, {name: s4, position: [2.1, 0.2, 4]},\n"
         "          {name: s8, position: [2.1, 0.2, 8]}]\n";
}

double largest_vertex_difference(const std::vector<V3>& u, const std::vector<V3>& v) {
  double m = 0.0;
  for (std::size_t i = 0; i < u.size(); ++i) m = std::max(m, (u[i] - v[i]).norm());
  return m;
}

}  // namespace

TEST(ProcedureStay, NeedleThatStaysHoldsTheTissueForTheNext) {
  const Scenario sc = parse_scenario_text(two_needles(true), 3, "plan.yaml");
  ASSERT_EQ(sc.needles.size(), 2u);
  EXPECT_TRUE(sc.needles[0].stay);
  EXPECT_EQ(sc.needles[0].withdraw_steps, 0);
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, o);
  const NeedleRun<3>& a = res.needles.at(0);
  const NeedleRun<3>& b = res.needles.at(1);
  ASSERT_EQ(a.depth.size(), 7u);   // in, never out
  ASSERT_EQ(b.depth.size(), 13u);  // in and out
  EXPECT_GT(a.active_points.back(), 0);
  const std::vector<V3>& left = a.vertex_displacement.back();
  EXPECT_GT(max_norm(left), 0.1);  // the stuck needle a has dragged the tissue
  // b starts from the tissue as a left it (every vertex, and the targets), and once b is out again the
  // tissue is back there: a's stations still hold it.
  EXPECT_LT(largest_vertex_difference(b.vertex_displacement.front(), left), 1e-9);
  EXPECT_LT(largest_vertex_difference(b.vertex_displacement.back(), left), 1e-9);
  for (std::size_t t = 0; t < 3; ++t) {
    EXPECT_LT((b.target_displacement.front()[t] - a.target_displacement.back()[t]).norm(), 1e-9) << t;
    EXPECT_LT((b.target_displacement.back()[t] - a.target_displacement.back()[t]).norm(), 1e-9) << t;
  }
  EXPECT_GT(a.target_displacement.back()[0].norm(), 1e-2);  // the point between the needles moved
  // b's seeds: their rest state is a's field at the planned position, so error = u_a(P) − u_release(P).
  ASSERT_EQ(b.seeds.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& seed = b.seeds[i];
    const V3 rest = a.target_displacement.back()[i + 1];
    EXPECT_LT((seed.rest_displacement - rest).norm(), 1e-9) << "seed " << i;
    const V3 at_release = b.target_displacement.at(static_cast<std::size_t>(seed.release_step))[i + 1];
    EXPECT_LT((seed.error() - (rest - at_release)).norm(), 1e-8) << "seed " << i;
  }
}

// The held rows condensed with the next needle's (one Schur system per solve) against the monolithic
// saddle-point solve of all rows at every step: the same fields, forces and targets.
TEST(ProcedureStay, HeldRowsMatchTheMonolithicSolve) {
  const Scenario sc = parse_scenario_text(two_needles(true), 3, "plan.yaml");
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> condensed = run_simulation<3>(axis_block(), sc, o);
  o.monolithic = true;
  const SimulationResult<3> monolithic = run_simulation<3>(axis_block(), sc, o);
  for (std::size_t n = 0; n < 2; ++n) {
    const NeedleRun<3>& c = condensed.needles.at(n);
    const NeedleRun<3>& m = monolithic.needles.at(n);
    ASSERT_EQ(c.vertex_displacement.size(), m.vertex_displacement.size());
    for (std::size_t k = 0; k < c.vertex_displacement.size(); ++k) {
      EXPECT_LT(largest_vertex_difference(c.vertex_displacement[k], m.vertex_displacement[k]), 1e-8)
          << "needle " << n << " step " << k;
      EXPECT_NEAR(c.axial_force[k], m.axial_force[k], 1e-8 * std::max(1.0, std::abs(m.axial_force[k])))
          << "needle " << n << " step " << k;
      for (std::size_t t = 0; t < 3; ++t)
        EXPECT_LT((c.target_displacement[k][t] - m.target_displacement[k][t]).norm(), 1e-8)
            << "needle " << n << " step " << k << " target " << t;
    }
  }
}

TEST(ProcedureStay, WithoutStayTheNextNeedleStartsAtRest) {
  SimulationOptions o = quiet();
  o.keep_step_fields = true;
  const SimulationResult<3> res =
      run_simulation<3>(axis_block(), parse_scenario_text(two_needles(false), 3, "plan.yaml"), o);
  const NeedleRun<3>& a = res.needles.at(0);
  const NeedleRun<3>& b = res.needles.at(1);
  ASSERT_EQ(a.depth.size(), 13u);  // withdrawn before b (implicitly, with its own steps)
  EXPECT_LT(max_norm(a.vertex_displacement.back()), 1e-9);
  EXPECT_LT(max_norm(b.vertex_displacement.front()), 1e-9);
  EXPECT_LT(max_norm(b.vertex_displacement.back()), 1e-9);
  // The same b with a staying ends elsewhere: by a's field (checked above), so the two runs differ.
  const SimulationResult<3> stay =
      run_simulation<3>(axis_block(), parse_scenario_text(two_needles(true), 3, "plan.yaml"), o);
  EXPECT_GT(largest_vertex_difference(stay.needles.at(1).vertex_displacement[6], b.vertex_displacement[6]),
            0.05);
}

TEST(ProcedureStay, BadStayNamesTheFileLineAndKey) {
  const std::string a =
      "{name: a, entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
      "friction: {model: stick}";
  const std::string b =
      "{name: b, entry: [2, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, "
      "friction: {model: stick}";
  std::string e =
      procedure_parse_error(kStayHead + "procedure:\n  - insert: " + a + ", stay: true, seeds: [4]}\n");
  EXPECT_NE(e.find("plan.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[0].insert.stay = true with seeds"), std::string::npos) << e;
  e = procedure_parse_error(kStayHead + "procedure:\n  - insert: " + a + ", seeds: [4]}\n  - insert: " + b +
                            ", stay: true}\n");
  EXPECT_NE(e.find("plan.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[1].insert.stay = true after a needle that released seeds"), std::string::npos)
      << e;
  e = procedure_parse_error(kStayHead + "procedure:\n  - insert: " + a + ", stay: maybe}\n");
  EXPECT_NE(e.find("procedure[0].insert.stay"), std::string::npos) << e;
  // A staying needle is held on the linear model only.
  std::string neo = kStayHead;
  ASSERT_EQ(neo.rfind("material: {}", 0), 0u) << neo;
  neo.replace(0, std::string("material: {}").size(), "material: {model: neo-hookean}");
  e = procedure_parse_error(neo + "procedure:\n  - insert: " + a + ", stay: true}\n  - insert: " + b + "}\n");
  EXPECT_NE(e.find("material.model = 'neo-hookean' with a needle left in the tissue (stay: true"),
            std::string::npos)
      << e;
}

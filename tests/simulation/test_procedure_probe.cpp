// The TRUS probe as a moving rigid body (`probe:` and the procedure's probe actions, docs/procedure.md):
// the tissue is bonded to the probe through an elastic foundation whose base follows the probe's rigid
// motion. Truth: the same foundation with its base displaced, solved once by a model built here (the fem
// API directly, its lattice of points rebuilt from the rule in scenario.hpp), gives the targets'
// displacement of every probe step; the force on the probe equals the fixed face's reaction of that
// solve (equilibrium: they are the only forces on the tissue); its moment is the brute-force sum over the
// foundation's points of that solve.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <vector>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// Block [-6,6]² × [0,24] (E = 10, ν = 0.49), its face y = 6 fixed; the probe a cylinder along z at
// (0, −4) of radius 1.5, bonded with k = 40 on a lattice of pitch 0.5.
const std::string kHead =
    "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: y_max}}]\n"
    "probe: {region: {cylinder: {center: [0, -4, 12], axis: [0, 0, 1], radius: 1.5}}, "
    "support: {elastic: {stiffness: 40, spacing: 0.5}}}\n"
    "targets: [{name: near, position: [0.3, -1.8, 12.2]}, {name: far, position: [3, 2, 6]}]\n";
const V3 kCenter(0, -4, 12), kAxis(0, 0, 1);
constexpr double kRadius = 1.5, kPitch = 0.5, kStiffness = 40.0;

// The foundation's lattice (scenario.hpp, BoundaryConditionSpec::Support::elastic): centre + (i + ½)·h
// per axis, inside the cylinder (within length/2 of its centre along the axis when length > 0) and the box.
std::vector<V3> lattice(double length = 0.0) {
  std::vector<V3> points;
  for (int i = -30; i < 30; ++i)
    for (int j = -30; j < 30; ++j)
      for (int k = -60; k < 60; ++k) {
        const V3 x = kCenter + kPitch * V3(i + 0.5, j + 0.5, k + 0.5);
        const V3 r = x - kCenter;
        if ((r - r.dot(kAxis) * kAxis).norm() > kRadius) continue;
        if (length > 0.0 && std::abs(r.dot(kAxis)) > 0.5 * length) continue;
        if (std::abs(x[0]) > 6 || std::abs(x[1]) > 6 || x[2] < 0 || x[2] > 24) continue;
        points.push_back(x);
      }
  return points;
}

struct Reference {
  std::vector<V3> targets;
  V3 reaction, moment;
};

// The block with the foundation's base at the probe's pose (t, θ), solved once from scratch.
Reference reference(const MeshModel<3>& mm, const V3& t, double degrees, const std::vector<V3>& targets,
                    double length = 0.0) {
  fem::ElasticModel<3> model(mm.mesh, std::vector<double>(mm.mesh.n_cells(), 10.0), 0.49, 1);
  fem::DirichletBC<3> face;
  face.region = fem::box_face_region<3>(V3(-6, -6, 0), V3(6, 6, 24), 1, true, 1e-9);
  model.add_dirichlet(face);
  fem::VolumeSupport<3> sup;
  sup.name = "probe";
  sup.stiffness = kStiffness;
  sup.points = lattice(length);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(degrees * M_PI / 180.0, kAxis).toRotationMatrix();
  for (const V3& x : sup.points) {
    sup.weights.push_back(std::pow(kPitch, 3));
    sup.base.push_back(R * (x - kCenter) + kCenter + t - x);
  }
  model.add_volume_support(sup);
  const fem::Solution<3> s = model.solve();
  Reference ref;
  ref.targets = model.sample(targets);
  ref.reaction = s.dirichlet_reaction.at(0);
  ref.moment = V3::Zero();
  const std::vector<V3> u = model.sample(sup.points);
  for (std::size_t p = 0; p < u.size(); ++p)
    ref.moment += (R * (sup.points[p] - kCenter)).cross(kStiffness * sup.weights[p] * (u[p] - sup.base[p]));
  return ref;
}

}  // namespace

TEST(ProcedureProbe, MotionMovesTheTissueAsTheFoundationsDisplacedBase) {
  const Scenario sc = parse_scenario_text(kHead +
                                              "procedure:\n"
                                              "  - probe: {translate: [0, 0, 0.5], steps: 2}\n"
                                              "  - probe: {rotate: 10, steps: 2}\n",
                                          3, "plan.yaml");
  ASSERT_TRUE(sc.probe);
  ASSERT_EQ(sc.probe->motions.size(), 2u);
  const MeshModel<3> mm = axis_block();
  const SimulationResult<3> res = run_simulation<3>(mm, sc, quiet());
  ASSERT_EQ(res.probe_steps.size(), 4u);
  EXPECT_EQ(res.report["probe"]["points"].get<std::size_t>(), lattice().size());  // 1,536
  const std::vector<V3> targets = {V3(0.3, -1.8, 12.2), V3(3, 2, 6)};
  for (const ProbeStep<3>& step : res.probe_steps) {
    const std::string at = "action " + std::to_string(step.action) + " step " + std::to_string(step.step);
    const Reference ref = reference(mm, step.translation, step.angle, targets);
    for (std::size_t t = 0; t < 2; ++t)
      EXPECT_LT((step.target_displacement.at(t) - ref.targets[t]).norm(), 1e-8) << at << " target " << t;
    EXPECT_LT((step.force - ref.reaction).norm(), 1e-8 * ref.reaction.norm()) << at;
    EXPECT_LT((step.moment - ref.moment).norm(), 1e-8 * ref.moment.norm()) << at;
  }
  // The poses: T·i/K, then the rotation on top of the translation.
  EXPECT_LT((res.probe_steps[0].translation - V3(0, 0, 0.25)).norm(), 1e-15);
  EXPECT_LT((res.probe_steps[3].translation - V3(0, 0, 0.5)).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(res.probe_steps[1].angle, 0.0);
  EXPECT_DOUBLE_EQ(res.probe_steps[2].angle, 5.0);
  EXPECT_DOUBLE_EQ(res.probe_steps[3].angle, 10.0);
  // The tissue near the probe follows it (along the axis, then around it); the far tissue much less.
  EXPECT_GT(res.probe_steps[1].target_displacement[0][2], 0.1);
  EXPECT_GT(res.probe_steps[1].force.norm(), 1.0);
  EXPECT_LT(res.probe_steps[1].target_displacement[1].norm(),
            res.probe_steps[1].target_displacement[0].norm());
  // The turn about +z (right-handed): the tissue resists it with a moment about −z on the probe.
  EXPECT_LT(res.probe_steps[3].moment[2], 0.0);
}

// A probe of finite length (its cylinder 8 mm long about z = 12, ending inside the block): the foundation
// covers that part only, and a translation moves the targets as the reference model with that lattice.
TEST(ProcedureProbe, FiniteProbeIsBondedOverItsLengthOnly) {
  std::string head = kHead;
  const std::string infinite = "radius: 1.5}";
  head.replace(head.find(infinite), infinite.size(), "radius: 1.5, length: 8}");
  const Scenario sc = parse_scenario_text(
      head + "procedure:\n  - probe: {translate: [0, 0.3, 0.5], steps: 1}\n", 3, "plan.yaml");
  ASSERT_DOUBLE_EQ(sc.probe->hold.region.length, 8.0);
  const MeshModel<3> mm = axis_block();
  const SimulationResult<3> res = run_simulation<3>(mm, sc, quiet());
  const std::vector<V3> full = lattice(), part = lattice(8.0);
  EXPECT_EQ(res.report["probe"]["points"].get<std::size_t>(), part.size());
  EXPECT_LT(part.size(), full.size() / 2);  // 8 of the block's 24 mm
  const std::vector<V3> targets = {V3(0.3, -1.8, 12.2), V3(3, 2, 6)};
  const ProbeStep<3>& step = res.probe_steps.at(0);
  const Reference ref = reference(mm, step.translation, 0.0, targets, 8.0);
  const Reference whole = reference(mm, step.translation, 0.0, targets);
  for (std::size_t t = 0; t < 2; ++t) {
    EXPECT_LT((step.target_displacement.at(t) - ref.targets[t]).norm(), 1e-8) << t;
    EXPECT_GT((ref.targets[t] - whole.targets[t]).norm(), 1e-4) << t;  // the length matters
  }
  EXPECT_LT((step.force - ref.reaction).norm(), 1e-8 * ref.reaction.norm());
  EXPECT_LT(step.force.norm(), whole.reaction.norm());
}

// A needle after the motion starts from the tissue the probe left (the moved base is a load of every later
// solve), and once it is withdrawn the tissue is back there (linear elasticity holds no memory).
TEST(ProcedureProbe, NeedleAfterTheMotionStartsFromTheMovedTissue) {
  const Scenario sc =
      parse_scenario_text(kHead +
                              "procedure:\n"
                              "  - probe: {translate: [0, 0.2, 0.5], steps: 1}\n"
                              "  - insert: {name: a, entry: [2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, "
                              "steps: 4, diameter: 1, friction: {model: stick}}\n",
                          3, "plan.yaml");
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, quiet());
  ASSERT_EQ(res.probe_steps.size(), 1u);
  ASSERT_EQ(res.needles.size(), 1u);
  const NeedleRun<3>& a = res.needles[0];
  ASSERT_EQ(a.depth.size(), 9u);  // in and out
  for (std::size_t t = 0; t < 2; ++t) {
    const V3 left = res.probe_steps[0].target_displacement[t];
    EXPECT_GT(left.norm(), 1e-3) << t;
    EXPECT_LT((a.target_displacement.front()[t] - left).norm(), 1e-9) << t;
    EXPECT_LT((a.target_displacement.back()[t] - left).norm(), 1e-9) << t;
  }
}

// A needle left in keeps holding its tissue while the probe moves: the motion's solves hold its rows, and
// the next needle's step 0 (the same held rows and moved base, read through the same near fields) finds the
// targets where the motion's last step put them; without the needle left in the motion moves them elsewhere.
TEST(ProcedureProbe, NeedleLeftInHoldsItsTissueThroughTheMotion) {
  const auto plan = [](bool stay) {
    return kHead +
           "procedure:\n  - insert: {name: a, entry: [2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, "
           "steps: 4, diameter: 1, friction: {model: stick}, stay: " +
           (stay ? "true" : "false") +
           "}\n  - probe: {translate: [0, 0, 0.5], steps: 2}\n"
           "  - insert: {name: b, entry: [-2.1, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 4, "
           "diameter: 1, friction: {model: stick}}\n";
  };
  const SimulationResult<3> held =
      run_simulation<3>(axis_block(), parse_scenario_text(plan(true), 3, "plan.yaml"), quiet());
  const SimulationResult<3> free =
      run_simulation<3>(axis_block(), parse_scenario_text(plan(false), 3, "plan.yaml"), quiet());
  ASSERT_EQ(held.probe_steps.size(), 2u);
  ASSERT_EQ(held.needles.size(), 2u);
  for (std::size_t t = 0; t < 2; ++t) {
    const V3 left = held.probe_steps.back().target_displacement[t];
    EXPECT_LT((held.needles[1].target_displacement.front()[t] - left).norm(), 1e-9) << t;
    EXPECT_LT(
        (free.needles[1].target_displacement.front()[t] - free.probe_steps.back().target_displacement[t])
            .norm(),
        1e-9)
        << t;
  }
  EXPECT_GT((held.probe_steps.back().target_displacement[0] - free.probe_steps.back().target_displacement[0])
                .norm(),
            1e-3);
}

TEST(ProcedureProbe, BadProbeActionsNameTheFileLineAndKey) {
  const std::string procedure = "procedure:\n  - probe: ";
  std::string e = procedure_parse_error(
      "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: y_max}}]\n" + procedure +
      "{translate: [0, 0, 1], steps: 2}\n");
  EXPECT_NE(e.find("plan.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[0].probe: the scenario has no 'probe'"), std::string::npos) << e;
  e = procedure_parse_error(kHead + procedure + "{translate: [0, 0, 1], rotate: 5, steps: 2}\n");
  EXPECT_NE(e.find("plan.yaml:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[0].probe: give either translate or rotate, not both"), std::string::npos) << e;
  e = procedure_parse_error(kHead + procedure + "{rotate: 5, steps: 0}\n");
  EXPECT_NE(e.find("procedure[0].probe.steps must be in 1..1000000, got 0"), std::string::npos) << e;
  e = procedure_parse_error(kHead + procedure + "{translate: [0, a, 1], steps: 2}\n");
  EXPECT_NE(e.find("procedure[0].probe.translate[1] must be a number, got 'a'"), std::string::npos) << e;
  e = procedure_parse_error(kHead + procedure + "{rotate: ten, steps: 2}\n");
  EXPECT_NE(e.find("procedure[0].probe.rotate must be a number, got 'ten'"), std::string::npos) << e;
  e = procedure_parse_error(kHead + procedure + "{steps: 2}\n");
  EXPECT_NE(e.find("procedure[0].probe needs translate"), std::string::npos) << e;
  e = procedure_parse_error(
      "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: y_max}}]\n"
      "probe: {region: {sphere: {center: [0, 0, 1], radius: 2}}, support: {elastic: {stiffness: 4}}}\n");
  EXPECT_NE(e.find("plan.yaml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("probe.region must be a cylinder"), std::string::npos) << e;
  e = procedure_parse_error(
      "material: {model: neo-hookean}\nboundary_conditions: [{type: fixed, region: {box_face: y_max}}]\n" +
      kHead.substr(kHead.find("probe:")) + procedure + "{rotate: 5, steps: 2}\n");
  EXPECT_NE(e.find("material.model = 'neo-hookean' with a probe motion"), std::string::npos) << e;
}

TEST(ProcedureProbe, RefusedOverMpiRanksAndWithCompareLinear) {
  const Scenario sc =
      parse_scenario_text(kHead + "procedure:\n  - probe: {rotate: 5, steps: 1}\n", 3, "plan.yaml");
  SimulationOptions o = quiet();
  o.mpi_ranks = 2;
  try {
    run_simulation<3>(axis_block(), sc, o);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_NE(
        std::string(e.what()).find("plan.yaml:3: probe: the probe's elastic foundation is solved on one "
                                   "process; run without --mpi-ranks"),
        std::string::npos)
        << e.what();
  }
  o.mpi_ranks = 1;
  o.compare_linear = true;
  try {
    run_simulation<3>(axis_block(), sc, o);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_NE(
        std::string(e.what()).find("plan.yaml:3: probe: --compare-linear with a probe motion is not built"),
        std::string::npos)
        << e.what();
  }
}

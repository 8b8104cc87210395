// The flexible needle (needle.flexible: the shaft an Euler–Bernoulli beam coupled to the stations in one
// linear system per step) through the simulation: with a needle a million times stiffer than steel it is
// the rigid needle (forces and targets), and on a mirror-symmetric model without a lateral load it does
// not deviate.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vim/pipeline/simulation/simulation.hpp>

#include "../simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// The needle along z from the origin (the symmetric block's axis), a target beside the path ahead of the
// tip and one beside the shaft; `flexible`: the needle.flexible mapping, or empty (rigid).
std::string needle_yaml(const std::string& flexible, const std::string& friction) {
  std::string n =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, friction: " + friction;
  if (!flexible.empty()) n += ", flexible: " + flexible;
  return n + "}";
}
const char* kTargets = "[{name: ahead, position: [1, 0.5, 15]}, {name: beside, position: [2, 1, 6]}]";

const char* kStickFriction = "{model: stick}";

NeedleRun<3> run(const std::string& flexible, const MeshModel<3>& model,
                 const std::string& friction = kStickFriction) {
  const Scenario sc = parse_scenario_text(yaml(needle_yaml(flexible, friction), kTargets), 3);
  return run_simulation<3>(model, sc, quiet()).needles.at(0);
}

}  // namespace

// E × 10⁶ (steel: 2e8 kPa → 2e14): the beam barely bends, so the forces per step (axial, lateral, per
// station) and the targets equal the rigid needle's. The block, clamped at z_max, lies off-centre about
// the needle, so the tissue pushes it sideways: the lateral coupling is exercised.
TEST(FlexibleNeedle, StiffNeedleIsTheRigidNeedle) {
  const MeshModel<3> model = block(V3(-2, -3, 0), V3(6, 6, 24), {{5, 6, 13}}, [](const V3&) { return 10.0; });
  // Stick (one solve per step) and stick-slip (the axial map's probes and the active set).
  for (const std::string friction : {kStickFriction, "{model: stick-slip, max_shear_per_length: 0.5}"}) {
    const NeedleRun<3> rigid = run("", model, friction);
    const NeedleRun<3> stiff = run("{youngs_modulus: 2.0e+14, inner_diameter: 0.6}", model, friction);
    // A soft rod (E = 2 MPa) bends visibly in 10 kPa tissue over 12 mm.
    const NeedleRun<3> soft = run("{youngs_modulus: 2.0e+3, inner_diameter: 0.6}", model, friction);
    ASSERT_EQ(rigid.depth.size(), stiff.depth.size());
    ASSERT_GT(rigid.lateral_force.back(), 1e-3 * rigid.axial_force.back());  // an asymmetric mesh
    double worst = 0.0, worst_soft = 0.0;
    for (std::size_t k = 1; k < rigid.depth.size(); ++k) {
      const double scale = rigid.force[k].norm();
      worst = std::max(worst, (stiff.force[k] - rigid.force[k]).norm() / scale);
      worst_soft = std::max(worst_soft, (soft.force[k] - rigid.force[k]).norm() / scale);
      for (std::size_t j = 0; j < rigid.point_axial_force[k].size(); ++j)
        EXPECT_NEAR(stiff.point_axial_force[k][j], rigid.point_axial_force[k][j], 1e-5 * scale)
            << friction << ", step " << k << ", point " << j;
      for (std::size_t t = 0; t < 2; ++t) {
        const double u = rigid.target_displacement[k][t].norm();
        EXPECT_LT((stiff.target_displacement[k][t] - rigid.target_displacement[k][t]).norm(), 1e-5 * u)
            << friction << ", step " << k;
      }
      EXPECT_LT(stiff.tip_deviation[k].norm(), 1e-5 * soft.tip_deviation[k].norm() + 1e-12) << k;
    }
    std::printf("%s: stiff vs rigid max |dF|/|F| = %.2e; soft vs rigid %.2e; soft tip deviation %.3e mm\n",
                friction.c_str(), worst, worst_soft, soft.tip_deviation.back().norm());
    EXPECT_LT(worst, 1e-5) << friction;
    // The soft rod bends: the flexible needle is not the rigid one (the comparison above can fail).
    EXPECT_GT(worst_soft, 1e-3) << friction;
    EXPECT_GT(soft.tip_deviation.back().norm(), 1e-3) << friction;
  }
}

// A soft rod in the off-centre block bends (tip deviation 0.54 mm): the beam's base holds the lateral
// force the tissue puts on the needle (global equilibrium: the beam's reaction against the tissue's
// solved forces, which a beam solved without the tissue's lateral stiffness would not balance).
TEST(FlexibleNeedle, BaseHoldsTheLateralForceOfTheTissue) {
  const MeshModel<3> model = block(V3(-2, -3, 0), V3(6, 6, 24), {{5, 6, 13}}, [](const V3&) { return 10.0; });
  const NeedleRun<3> soft = run("{youngs_modulus: 2.0e+3, inner_diameter: 0.6}", model);
  ASSERT_GT(soft.tip_deviation.back().norm(), 0.1);
  for (std::size_t k = 1; k < soft.depth.size(); ++k) {
    const V3 lateral = soft.force[k] - soft.force[k].dot(soft.axis) * soft.axis;
    EXPECT_LT((soft.base_force[k] + lateral).norm(), 1e-8 * lateral.norm()) << "step " << k;
  }
}

// The block mirrored about x = 0 and y = 0 with the needle on its axis and no bevel: no lateral load, so
// the flexible needle stays on the planned line.
TEST(FlexibleNeedle, SymmetricModelWithoutBevelDoesNotDeviate) {
  const NeedleRun<3> r = run("{youngs_modulus: 2.0e+5, inner_diameter: 0.6, free_length: 5}", axis_block());
  ASSERT_EQ(r.tip_deviation.size(), r.depth.size());
  for (std::size_t k = 0; k < r.depth.size(); ++k) {
    EXPECT_LT(r.tip_deviation[k].norm(), 1e-9) << "step " << k;
    EXPECT_LT(r.base_force[k].norm(), 1e-9 * std::max(1.0, r.axial_force[k])) << "step " << k;
  }
  EXPECT_GT(r.axial_force.back(), 0.0);
}

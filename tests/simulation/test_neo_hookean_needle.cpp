// The kinematic needle on neo-Hookean tissue (material.model: neo-hookean; docs/finite-strain.md,
// "Needle insertion"): the rows on the Newton solve against Dirichlet conditions on the same nodes, the
// tangent axial map against central differences of the solve, the small-load limit (the linear model),
// mesh convergence, a monotone stick-slip force, and the refused combinations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>
#include <vim/fem/finite_strain.hpp>
#include <vim/fem/finite_strain_rows.hpp>
#include <vim/needle/neo_hookean_tissue.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace neo_hookean_needle_test {

const V3 kLo(0, 0, 0), kHi(4, 4, 6);

// A block of Kuhn tetrahedra (P1) with moduli 10–20 per cell, its bottom z = 0 held.
fem::ElasticModel<3> small_block() {
  const SimplexMesh<3> mesh = regular_grid_mesh<3>(kLo, kHi, {{4, 4, 5}});
  std::vector<double> E;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    E.push_back(10.0 + 10.0 * static_cast<double>((c * 7) % 5) / 4.0);
  fem::ElasticModel<3> model(mesh, E, 0.4, 1);
  fem::DirichletBC<3> bottom;
  bottom.region = fem::box_face_region<3>(kLo, kHi, 2, false, 1e-9);
  model.add_dirichlet(bottom);
  return model;
}

// Point-constraint rows at the vertices of the top face z = 6 (every component) hold exactly what a
// Dirichlet condition on that face holds: the Newton solve with rows equals solve_neo_hookean with the
// condition (a shear and an 8% compression) at probes inside, and the rows' forces on the body sum to
// the condition's reaction (the force it applies to the body), within 1e-6.
TEST(NeoHookeanNeedle, RowsAtFaceVerticesEqualTheDirichletSolve) {
  const V3 d(0.2, -0.1, -0.5);
  const std::vector<V3> probes = {V3(1.1, 2.3, 3.1), V3(2.9, 0.7, 4.6), V3(2.0, 2.0, 1.5)};
  fem::ElasticModel<3> ref = small_block();
  fem::DirichletBC<3> top;
  top.region = fem::box_face_region<3>(kLo, kHi, 2, true, 1e-9);
  top.value = d;
  ref.add_dirichlet(top);
  const fem::FiniteStrainSolution<3> fs = fem::solve_neo_hookean(ref);
  const std::vector<V3> u_ref = ref.sample(probes);
  const V3 reaction = fs.solution.dirichlet_reaction[1];

  fem::ElasticModel<3> model = small_block();
  std::vector<fem::PointConstraint<3>> points;
  for (const V3& p : model.vertices())
    if (std::abs(p[2] - kHi[2]) < 1e-9) points.emplace_back(p);
  fem::FiniteStrainRows<3> rows(model, points, probes);
  std::vector<std::size_t> active(points.size());
  for (std::size_t i = 0; i < active.size(); ++i) active[i] = i;
  rows.solve(active, std::vector<V3>(points.size(), d));
  std::vector<V3> force;
  rows.point_forces(force);
  V3 total = V3::Zero();
  for (const V3& f : force) total += f;
  for (std::size_t p = 0; p < probes.size(); ++p)
    EXPECT_LT((rows.probe_displacements()[p] - u_ref[p]).norm(), 1e-6 * d.norm()) << p;
  ASSERT_GT(reaction.norm(), 1.0);
  EXPECT_LT((total - reaction).norm(), 1e-6 * reaction.norm())
      << total.transpose() << " / " << reaction.transpose();
  for (std::size_t i = 0; i < points.size(); ++i)
    EXPECT_LT((rows.held_displacement(i) - d).norm(), 1e-9) << i;
}

// Averaged rows with a compliance in series (a band) pulled 1 mm (strains of ~25%): the change of the
// forces by linearised_forces (the tangent's condensed compliance at the converged state) equals the
// central difference of two Newton solves within 1e-5 of its size, and differs from the linear model's
// compliance (the tangent at the undeformed state) by more than 1%.
TEST(NeoHookeanNeedle, LinearisedForcesAreTheDerivativeOfTheSolve) {
  fem::ElasticModel<3> model = small_block();
  std::vector<fem::PointConstraint<3>> points;
  for (const double z : {2.5, 4.0, 5.5}) {
    fem::PointConstraint<3> p(V3(2.1, 1.9, z));
    for (int k = 0; k < 8; ++k) {
      const double a = k * M_PI / 4.0;
      p.offsets.emplace_back(0.9 * std::cos(a), 0.9 * std::sin(a), 0.0);
      p.weights.push_back(1.0);
    }
    p.compliance = V3(0.01, 0.01, 0.02);
    points.push_back(p);
  }
  const std::vector<std::size_t> active = {0, 1, 2};
  const std::vector<V3> g = {V3(0.2, 0.0, 1.0), V3(0.1, 0.1, 1.0), V3(0.0, -0.2, 0.8)};
  const std::vector<V3> dg = {V3(0.3, -0.2, 1.0), V3(0.0, 0.5, -0.4), V3(0.7, 0.1, 0.2)};
  fem::FiniteStrainRows<3> rows(model, points, {});
  const auto forces_at = [&](double h) {
    std::vector<V3> gh(3);
    for (int i = 0; i < 3; ++i) gh[i] = g[i] + h * dg[i];
    rows.solve(active, gh);
    std::vector<V3> f;
    rows.point_forces(f);
    return f;
  };
  const double h = 1e-4;
  const std::vector<V3> fp = forces_at(h), fm = forces_at(-h);
  forces_at(0.0);
  std::vector<V3> lin;
  rows.linearised_forces(dg, lin);
  // the linear model's compliance: the same rows on the tangent at the undeformed state
  fem::ElasticModel<3> model0 = small_block();
  fem::FiniteStrainRows<3> rows0(model0, points, {});
  rows0.solve(active, std::vector<V3>(3, V3::Zero()));
  std::vector<V3> lin0;
  rows0.linearised_forces(dg, lin0);
  double size = 0.0, err = 0.0, err0 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const V3 fd = (fp[i] - fm[i]) / (2.0 * h);
    size = std::max(size, fd.norm());
    err = std::max(err, (lin[i] - fd).norm());
    err0 = std::max(err0, (lin0[i] - fd).norm());
  }
  EXPECT_LT(err, 1e-5 * size) << err << " / " << size;
  EXPECT_GT(err0, 1e-2 * size) << err0 << " / " << size;
}

// The needle along z on the axis of the symmetric block (E = 10 kPa, ν = 0.3 by default), stick-slip
// with the limit q and cutting force fc, two targets beside the path.
const char* kTargets = "[{name: ahead, position: [1, 0.5, 15]}, {name: beside, position: [2, 1, 6]}]";
NeedleRun<3> insert(const std::string& model, double q, double fc, int steps = 6, double depth = 12,
                    const MeshModel<3>& mesh = axis_block(), const std::string& targets = kTargets) {
  std::ostringstream n;
  n << "{entry: [0, 0, 0], direction: [0, 0, 1], depth: " << depth << ", steps: " << steps
    << ", diameter: 1, friction: {model: stick-slip, max_shear_per_length: " << q
    << "}, cutting_force: " << fc << "}";
  const Scenario sc = parse_scenario_text(yaml(n.str(), targets, "{model: " + model + "}"), 3);
  return run_simulation<3>(mesh, sc, quiet()).needles.at(0);
}

double target_difference(const NeedleRun<3>& a, const NeedleRun<3>& b) {
  double diff = 0.0, size = 0.0;
  for (std::size_t k = 0; k < a.target_displacement.size(); ++k)
    for (std::size_t t = 0; t < a.target_displacement[k].size(); ++t) {
      diff = std::max(diff, (a.target_displacement[k][t] - b.target_displacement[k][t]).norm());
      size = std::max(size, b.target_displacement[k][t].norm());
    }
  return diff / size;
}

// As the friction limit and the cutting force go to 0 (strains ∝ the load), the neo-Hookean insertion
// tends to the linear one: the targets' displacements (largest over the steps and targets) and the axial
// forces differ by relative amounts that fall in proportion to the load (ratio < 0.15 per factor 10),
// below 1e-3 and 1e-4 at the smallest load.
TEST(NeoHookeanNeedle, SmallLoadsTendToTheLinearInsertion) {
  std::vector<double> target_rel, force_rel;
  for (const double s : {1.0, 0.1, 0.01}) {
    const NeedleRun<3> nh = insert("neo-hookean", 8.0 * s, 10.0 * s),
                       lin = insert("linear", 8.0 * s, 10.0 * s);
    target_rel.push_back(target_difference(lin, nh));
    double df = 0.0, fmax = 0.0;
    for (std::size_t k = 0; k < nh.axial_force.size(); ++k) {
      df = std::max(df, std::abs(nh.axial_force[k] - lin.axial_force[k]));
      fmax = std::max(fmax, std::abs(nh.axial_force[k]));
    }
    force_rel.push_back(df / fmax);
  }
  std::cout << "target relative difference: " << target_rel[0] << ", " << target_rel[1] << ", "
            << target_rel[2] << "; axial force: " << force_rel[0] << ", " << force_rel[1] << ", "
            << force_rel[2] << "\n";
  EXPECT_GT(target_rel[0], 1e-2);  // the models differ at the largest load
  for (int k : {1, 2}) {
    EXPECT_LT(target_rel[k], 0.15 * target_rel[k - 1]) << k;
    EXPECT_LT(force_rel[k], std::max(0.15 * force_rel[k - 1], 1e-6)) << k;
  }
  EXPECT_LT(target_rel[2], 1e-3);
  EXPECT_LT(force_rel[2], 1e-4);
}

// The kept (chord) axial map between the laws' rounds gives the insertion of a fresh tangent per map:
// the axial forces and the targets within 1e-6 (relative to the largest), both settled to
// kNonlinearForceTolerance; the kept map saves tangents at the cost of more solves.
TEST(NeoHookeanNeedle, KeptMapGivesTheInsertionOfFreshTangents) {
  const double ratio = needle::kept_map_miss_ratio;
  ASSERT_GT(ratio, 0.0);
  const NeedleRun<3> kept = insert("neo-hookean", 8.0, 10.0);
  needle::kept_map_miss_ratio = 0.0;
  const NeedleRun<3> fresh = insert("neo-hookean", 8.0, 10.0);
  needle::kept_map_miss_ratio = ratio;
  double df = 0.0, fmax = 0.0;
  for (std::size_t k = 0; k < fresh.axial_force.size(); ++k) {
    df = std::max(df, std::abs(kept.axial_force[k] - fresh.axial_force[k]));
    fmax = std::max(fmax, std::abs(fresh.axial_force[k]));
  }
  ASSERT_GT(fmax, 1.0);
  EXPECT_LT(df, 1e-6 * fmax);
  EXPECT_LT(target_difference(kept, fresh), 1e-6);
  int kept_solves = 0, fresh_solves = 0;
  for (std::size_t k = 0; k < fresh.solves.size(); ++k)
    kept_solves += kept.solves[k], fresh_solves += fresh.solves[k];
  EXPECT_NE(kept_solves, fresh_solves);  // the kept map was used: its rounds differ
}

// Stick-slip without cutting force: each step adds sliding or sticking shaft to a needle advancing in one
// direction, so the axial force never falls (within round-off of the Newton tolerance).
TEST(NeoHookeanNeedle, StickSlipForceRisesMonotonically) {
  const NeedleRun<3> nh = insert("neo-hookean", 6.0, 0.0, 8, 16);
  double fmax = 0.0;
  for (double f : nh.axial_force) fmax = std::max(fmax, std::abs(f));
  ASSERT_GT(fmax, 1.0);
  for (std::size_t k = 1; k < nh.axial_force.size(); ++k)
    EXPECT_GE(nh.axial_force[k], nh.axial_force[k - 1] - 1e-7 * fmax) << "step " << k;
}

// Convergence on a uniform block: the axial force at every step and the targets' final displacements
// of the two finest of three P1 meshes within 3% (of the largest force, of the largest target
// displacement); the targets lie outside the bands (radius 3h on P1, docs/needle-model.md §14), one
// ahead of the tip and one beside the shaft.
TEST(NeoHookeanNeedle, ForceCurveAndTargetsConvergeOnAUniformBlock) {
  std::vector<NeedleRun<3>> runs;
  for (const int n : {5, 7, 9}) {
    const MeshModel<3> mesh =
        block(V3(-8, -8, 0), V3(8, 8, 24), {{n, n, 2 * n - 1}}, [](const V3&) { return 10.0; });
    runs.push_back(insert("neo-hookean", 6.0, 5.0, 6, 12, mesh,
                          "[{name: ahead, position: [0.3, 0.2, 17]}, {name: beside, position: [6, 2, 8]}]"));
  }
  const NeedleRun<3>&a = runs[1], &b = runs[2];
  double fmax = 0.0, df = 0.0;
  for (std::size_t k = 0; k < b.axial_force.size(); ++k) {
    fmax = std::max(fmax, std::abs(b.axial_force[k]));
    df = std::max(df, std::abs(a.axial_force[k] - b.axial_force[k]));
  }
  double umax = 0.0, du = 0.0;
  for (std::size_t t = 0; t < b.target_displacement.back().size(); ++t) {
    umax = std::max(umax, b.target_displacement.back()[t].norm());
    du = std::max(du, (a.target_displacement.back()[t] - b.target_displacement.back()[t]).norm());
  }
  std::cout << "force: " << df / fmax << ", targets: " << du / umax << "\n";
  EXPECT_LT(df, 0.03 * fmax);
  EXPECT_LT(du, 0.03 * umax);
}

// A flexible needle on neo-Hookean tissue is refused naming both keys; over MPI ranks the neo-Hookean
// needle is refused naming material.model.
TEST(NeoHookeanNeedle, FlexibleNeedleAndMpiRanksAreRefused) {
  const std::string flexible =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, friction: {model: stick}, "
      "flexible: {youngs_modulus: 2.0e8, inner_diameter: 0.6}}";
  try {
    parse_scenario_text(yaml(flexible, "[]", "{model: neo-hookean}"), 3);
    FAIL() << "not refused";
  } catch (const ScenarioError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("material.model = 'neo-hookean' with a flexible needle (needle.flexible"),
              std::string::npos)
        << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  const Scenario sc = parse_scenario_text(yaml(kStick, "[]", "{model: neo-hookean}"), 3);
  SimulationOptions o = quiet();
  o.mpi_ranks = 2;
  try {
    run_simulation<3>(axis_block(), sc, o);
    FAIL() << "not refused";
  } catch (const ScenarioError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("material.model = 'neo-hookean' is solved on one process; run without --mpi-ranks"),
              std::string::npos)
        << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

}  // namespace neo_hookean_needle_test

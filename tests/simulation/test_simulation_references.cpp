// Needle simulation against reference solutions: the monolithic saddle-point solve at every step (for
// the kinematic models, and for the force model's prescribed forces with the condensed system set up by
// the test itself), and the analytic field of a layered column for the voxel and grid models.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>
#include <vim/initial_mesh.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/voxel_statistics.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {
using V3 = Eigen::Vector3d;
}  // namespace

namespace {

// The largest vertex displacement difference of two runs at step k, relative to the second's largest.
template <int dim>
double step_difference(const NeedleRun<dim>& f, const NeedleRun<dim>& m, std::size_t k) {
  double d = 0.0, scale = 0.0;
  for (std::size_t v = 0; v < f.vertex_displacement[k].size(); ++v) {
    d = std::max(d, (f.vertex_displacement[k][v] - m.vertex_displacement[k][v]).norm());
    scale = std::max(scale, m.vertex_displacement[k][v].norm());
  }
  return scale > 0.0 ? d / scale : d;
}

// Runs the scenario on the fast path (rows precomputed before stepping, dense work per step) and with
// the monolithic saddle-point solve at every step; every step's field and forces must agree.
template <int dim>
void expect_fast_path_matches_monolithic(const MeshModel<dim>& model, const Scenario& sc, unsigned degree,
                                         const std::string& label) {
  auto o = quiet();
  o.keep_step_fields = true;
  o.degree = degree;
  const auto fast = run_simulation<dim>(model, sc, o);
  o.monolithic = true;
  const auto mono = run_simulation<dim>(model, sc, o);
  const auto &f = fast.needles[0], &m = mono.needles[0];
  ASSERT_EQ(f.vertex_displacement.size(), m.vertex_displacement.size()) << label;
  EXPECT_EQ(f.active_points, m.active_points) << label;
  EXPECT_GT(f.active_points.back(), 1) << label;
  for (std::size_t k = 1; k < f.vertex_displacement.size(); ++k) {
    EXPECT_LT(step_difference<dim>(f, m, k), 1e-8) << label << ", step " << k;
    EXPECT_LE(std::abs(f.axial_force[k] - m.axial_force[k]), 1e-8 * std::abs(m.axial_force[k]))
        << label << ", step " << k;
    EXPECT_LE((f.force[k] - m.force[k]).norm(), 1e-8 * m.force[k].norm()) << label << ", step " << k;
  }
  if (!f.active_set_sweeps.empty()) {
    EXPECT_EQ(f.active_set_sweeps, m.active_set_sweeps) << label;
  }
}

const std::vector<std::pair<std::string, std::string>> kLaws = {
    {"stick", ", friction: {model: stick}"},
    {"stick-slip", ", friction: {model: stick-slip, max_shear_per_length: 3}"},
    {"force", ", model: force, tip_force: 5, friction_per_length: 0.4"}};

}  // namespace

// Truth: the monolithic saddle-point solve [K Cᵀ; C −κ] of every step (ElasticModel::solve_monolithic,
// UMFPACK), against the fast path (every shaft row's column precomputed before stepping, each step a
// dense Schur solve on the cached columns), for stick, stick-slip (the active set too) and the force
// model, P1 and P2, 3D.
TEST(Simulation, FastPathMatchesMonolithicSolveAtEveryStep) {
  for (const unsigned degree : {1u, 2u})
    for (const auto& [law, keys] : kLaws) {
      // P2: a shorter path (each monolithic solve of the P2 block costs ~50 P1 ones)
      const std::string needle = "{entry: [0.5, -0.3, 0], direction: [0.1, 0.05, 1], depth: " +
                                 std::string(degree == 1 ? "12, steps: 5" : "5, steps: 2") + ", diameter: 1" +
                                 keys + "}";
      const Scenario sc = parse_scenario_text(yaml(needle, "[{name: t, position: [1, 1, 18]}]"), 3);
      expect_fast_path_matches_monolithic<3>(axis_block(), sc, degree, law + " P" + std::to_string(degree));
    }
}

// Truth: as above, in 2D (plane strain).
TEST(Simulation, FastPathMatchesMonolithicSolveAtEveryStep2D) {
  MeshModel<2> m;
  m.mesh = regular_grid_mesh<2>(Eigen::Vector2d(-5, 0), Eigen::Vector2d(5, 20), {{11, 21}});
  m.values.assign(m.mesh.n_cells(), ElementValue{1, 10.0, 0.0});
  for (const unsigned degree : {1u, 2u})
    for (const auto& [law, keys] : kLaws) {
      const std::string needle =
          "{entry: [0.3, 0], direction: [0.05, 1], depth: 12, steps: 5, diameter: 1" + keys + "}";
      const Scenario sc = parse_scenario_text(
          yaml(needle, "[{name: t, position: [1, 15]}]", "{}", "[{type: fixed, region: {box_face: y_max}}]"),
          2);
      expect_fast_path_matches_monolithic<2>(m, sc, degree, law + " 2D P" + std::to_string(degree));
    }
}

// Truth: the monolithic saddle-point solve of every step (ElasticModel::solve_monolithic), against the
// forces-only steps of the real-time rate (SimulationOptions::step_fields = false: each step gives the
// forces and the targets' displacements from the condensed rows alone, the field only at the last
// step): forces, per-station axial forces, target displacements and the active set of every step, and
// the last step's field; 3D P1 with stick-slip and the force model, 2D P1 with stick-slip (P2 and stick:
// the condensed rows' own tests, tests/fem/test_condensed_constraints.cpp, and the test above).
TEST(Simulation, ForcesOnlyStepsMatchMonolithicSolveAtEveryStep) {
  MeshModel<2> plane;
  plane.mesh = regular_grid_mesh<2>(Eigen::Vector2d(-5, 0), Eigen::Vector2d(5, 20), {{11, 21}});
  plane.values.assign(plane.mesh.n_cells(), ElementValue{1, 10.0, 0.0});
  const auto check = [](const auto& model, const Scenario& sc, unsigned degree, const std::string& label) {
    constexpr int dim = std::decay_t<decltype(model.mesh.points[0])>::RowsAtCompileTime;
    auto o = quiet();
    o.degree = degree;
    o.step_fields = false;
    const auto fast = run_simulation<dim>(model, sc, o);
    o.monolithic = true;
    o.step_fields = true;
    const auto mono = run_simulation<dim>(model, sc, o);
    const auto &f = fast.needles[0], &m = mono.needles[0];
    EXPECT_EQ(f.active_points, m.active_points) << label;
    EXPECT_EQ(f.active_set_sweeps, m.active_set_sweeps) << label;
    for (std::size_t k = 1; k < m.depth.size(); ++k) {
      EXPECT_LE((f.force[k] - m.force[k]).norm(), 1e-8 * m.force[k].norm()) << label << ", step " << k;
      for (std::size_t j = 0; j < m.point_axial_force[k].size(); ++j)
        EXPECT_LE(std::abs(f.point_axial_force[k][j] - m.point_axial_force[k][j]), 1e-8 * m.force[k].norm())
            << label << ", step " << k << ", station " << j;
      for (std::size_t t = 0; t < m.target_displacement[k].size(); ++t)
        EXPECT_LE((f.target_displacement[k][t] - m.target_displacement[k][t]).norm(),
                  1e-8 * m.target_displacement[k][t].norm())
            << label << ", step " << k << ", target " << t;
    }
    EXPECT_TRUE(std::isnan(f.max_strain[1])) << label << ": a step whose field is not formed";
    EXPECT_NEAR(f.max_strain.back(), m.max_strain.back(), 1e-8 * m.max_strain.back()) << label;
    double d = 0.0, scale = 0.0;
    for (std::size_t v = 0; v < m.vertex_displacement.back().size(); ++v) {
      d = std::max(d, (f.vertex_displacement.back()[v] - m.vertex_displacement.back()[v]).norm());
      scale = std::max(scale, m.vertex_displacement.back()[v].norm());
    }
    EXPECT_LT(d, 1e-8 * scale) << label << ": the last step's field";
  };
  for (const std::size_t law : {1, 2}) {  // stick-slip and the force model (stick: the test above)
    const std::string needle =
        "{entry: [0.5, -0.3, 0], direction: [0.1, 0.05, 1], depth: 12, steps: 5, diameter: 1" +
        kLaws[law].second + "}";
    const Scenario sc = parse_scenario_text(yaml(needle, "[{name: t, position: [1, 1, 18]}]"), 3);
    check(axis_block(), sc, 1, kLaws[law].first + " P1");
  }
  const Scenario sc2 = parse_scenario_text(
      yaml("{entry: [0.3, 0], direction: [0.05, 1], depth: 12, steps: 5, diameter: 1" + kLaws[1].second + "}",
           "[{name: t, position: [1, 15]}]", "{}", "[{type: fixed, region: {box_face: y_max}}]"),
      2);
  check(plane, sc2, 1, "stick-slip 2D P1");
}

// Truth: the force model's problem solved by the test itself — the condensed axial stiffness of the
// active shaft stations (their band rows, vim::needle::needle_band_constraint) measured with monolithic
// saddle-point solves (ElasticModel::solve_monolithic, one per station), the axial values that give the
// prescribed forces (tip force on the last station, friction per length × the shaft length each carries,
// as needle.hpp states) solved with Eigen, and the
// field of one more monolithic solve — against every step of the simulation's fast path.
TEST(Simulation, ForceModelStepsMatchAMonolithicSolveOfThePrescribedForces) {
  // Entry inside the block, off the grid lines; targets on the axis 4 ahead of the tip and 4 behind the
  // entry.
  const std::string needle =
      "{entry: [0.3, -0.2, 8], direction: [0, 0, 1], depth: 6, steps: 3, diameter: 1, model: force, "
      "tip_force: 5, friction_per_length: 0.1, coupling_radius: 2}";  // a single ring of radius 2
  const Scenario sc = parse_scenario_text(
      yaml(needle, "[{name: ahead, position: [0.3, -0.2, 18]}, {name: behind, position: [0.3, -0.2, 4]}]",
           "{poisson_ratio: 0.3}",
           "[{type: fixed, region: {box_face: z_max}}, {type: fixed, region: {box_face: z_min}}]"),
      3);
  auto o = quiet();
  o.keep_step_fields = true;
  const auto res = run_simulation<3>(axis_block(), sc, o);
  const auto& r = res.needles[0];
  NeedleSimulation<3> reference(axis_block(), sc, quiet());
  fem::ElasticModel<3>& model = reference.model();
  const V3 entry(0.3, -0.2, 8), a(0, 0, 1);
  const std::size_t np = r.point_s.size();
  std::vector<double> start(np, 0.0);
  for (std::size_t j = 1; j < np; ++j) start[j] = start[j - 1] + r.point_length[j - 1];
  // The stations' bands (vim::needle::needle_band_constraint, the documented rows of the 3D needle) with the
  // coupling radius the run reports.
  vim::needle::NeedleBand band;
  band.radius = 0.5;
  band.coupling_radius = res.report["needles"][0]["coupling_radius"].get<double>();
  int steps_with_stations = 0;
  for (std::size_t k = 1; k < r.depth.size(); ++k) {
    const std::size_t n = static_cast<std::size_t>(r.active_points[k]);
    if (n == 0) continue;  // the tip has not reached the first station's band yet
    ++steps_with_stations;
    // Every station but the last carries its whole segment; the last one the cut part of its segment,
    // up to the tissue at the tip (pushed ahead of the tip by the needle's load, so a little short of
    // the tip): its length is read from its force and bounded here.
    Eigen::VectorXd F(n);
    for (std::size_t j = 0; j + 1 < n; ++j) F[j] = 0.1 * r.point_length[j];
    const double last_carried = (r.point_axial_force[k][n - 1] - 5.0) / 0.1;
    EXPECT_GT(last_carried, 0.0) << "step " << k;
    EXPECT_LE(last_carried, std::min(r.point_length[n - 1], r.depth[k] - start[n - 1]) + 1e-9)
        << "step " << k;
    F[n - 1] = 0.1 * last_carried + 5.0;
    auto solve = [&](const Eigen::VectorXd& w) {
      std::vector<fem::PointConstraint<3>> pts;
      for (std::size_t j = 0; j < n; ++j) {
        band.length = r.point_length[j];
        pts.push_back(vim::needle::needle_band_constraint(entry + r.point_s[j] * a, a, band, V3(0, 0, w[j]),
                                                          10.0, 0.3));
      }
      return model.solve_monolithic(pts);
    };
    Eigen::MatrixXd C(n, n);  // axial force on the body at point i for a unit axial value at point j
    for (std::size_t j = 0; j < n; ++j) {
      const auto s = solve(Eigen::VectorXd::Unit(n, j));
      for (std::size_t i = 0; i < n; ++i) C(i, j) = s.point_force[i].dot(a);
    }
    const auto s = solve(C.lu().solve(F));
    const double scale = max_norm(s.vertex_displacement);
    double d = 0.0;
    for (std::size_t v = 0; v < s.vertex_displacement.size(); ++v)
      d = std::max(d, (s.vertex_displacement[v] - r.vertex_displacement[k][v]).norm());
    EXPECT_LT(d, 1e-7 * scale) << "step " << k;
    for (std::size_t j = 0; j < n; ++j)
      EXPECT_NEAR(r.point_axial_force[k][j], F[j], 1e-7 * F.sum()) << "step " << k;
    EXPECT_NEAR(r.axial_force[k], F.sum(), 1e-7 * F.sum()) << "step " << k;
  }
  EXPECT_GE(steps_with_stations, 2);
  const V3 ahead = r.target_displacement.back()[0], behind = r.target_displacement.back()[1];
  EXPECT_GT(ahead[2], 0.0);  // the tip pushes the tissue ahead forward
  EXPECT_GT(behind[2], 0.0);
}

// Truth: the analytic field of a layered column under pressure. 6 layers of different moduli along z
// (two voxels thick), ν = 0, supports sliding on x_min, y_min and z_min, pressure p on z_max: the
// stress is σ_zz = −p in every layer, so u_x = u_y = 0 and u_z(z) = −p ∫₀^z dζ / (scale·E(ζ)), linear
// in each layer. Both the voxel reference (Q1) and the grid mesh with its nodes on the layer faces (P1,
// element means from the mesher's VoxelStatistics; one cell per 2×2×2 voxels, so that a tetrahedron
// holding no voxel centre takes the interpolated value at its centroid from its own layer) represent it
// exactly: agreement to round-off.
// (A needle's own field has no converged reference: point constraints on a line are singular in 3D.)
TEST(Simulation, VoxelAndGridModelsReproduceTheLayeredColumnUnderPressure) {
  Image<3> img({{6, 6, 12}}, {{2, 2, 2}}, {{-5, -5, 1}});  // box [-6,6]^2 x [0,24]
  auto layer_modulus = [](long k) { return 10.0 * (1.0 + 0.3 * static_cast<double>(k)); };
  for (std::size_t v = 0; v < img.voxel_count(); ++v)
    img.data[v] = static_cast<float>(layer_modulus(img.index_of(v)[2] / 2));
  const double scale = 2.0, p = 1.5;
  const Scenario sc = parse_scenario_text(
      yaml("{entry: [0.3, -0.2, 6], direction: [0, 0, 1], depth: 2, steps: 1, diameter: 1, friction: {model: "
           "stick}}",
           "[]", "{youngs_modulus: image, scale: 2, poisson_ratio: 0}",
           "[{type: fixed, region: {box_face: x_min}, components: [x]}, {type: fixed, region: {box_face: "
           "y_min}, "
           "components: [y]}, {type: fixed, region: {box_face: z_min}, components: [z]}, {type: pressure, "
           "region: "
           "{box_face: z_max}, value: 1.5}]"),
      3);
  auto exact = [&](const V3& x) {
    double uz = 0.0;
    for (long k = 0; k < 6; ++k) uz -= p * std::clamp(x[2] - 4.0 * k, 0.0, 4.0) / (scale * layer_modulus(k));
    return V3(0, 0, uz);
  };
  auto o = quiet();
  o.keep_step_fields = true;
  auto expect_exact = [&](NeedleSimulation<3>& sim, const char* which) {
    const auto r = sim.run().needles[0];
    const auto& u = r.vertex_displacement[0];  // step 0: the pressure alone
    const auto& x = sim.model().vertices();
    ASSERT_EQ(u.size(), x.size());
    double err = 0.0, top = 0.0;
    for (std::size_t v = 0; v < x.size(); ++v) {
      err = std::max(err, (u[v] - exact(x[v])).norm());
      top = std::max(top, exact(x[v]).norm());
    }
    EXPECT_GT(top, 0.05) << which;
    EXPECT_LT(err, 1e-8 * top) << which;
  };
  auto voxel = NeedleSimulation<3>::voxel(img, WorldTransform<3>{}, sc, o);
  EXPECT_EQ(voxel.youngs_modulus().size(), 432u);
  expect_exact(voxel, "voxel model");
  MeshModel<3> grid;
  grid.mesh = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{4, 4, 7}});
  const VoxelStatistics<3> stats(img);
  for (std::size_t c = 0; c < grid.mesh.n_cells(); ++c)
    grid.values.push_back(stats.value(cell_points(grid.mesh, c)));
  NeedleSimulation<3> simplex(grid, sc, o);
  expect_exact(simplex, "grid mesh");
}

// The 3D needle of finite radius through the whole simulation (BandCoupling in NeedleInsertion). Truths:
// antiplane shear theory (a rigid shaft of radius a in a prism of square section s with held long faces
// carries 2πG·U/ln(ρ/a) per length, ρ = 0.5394·s, so the force ratio of two diameters is
// ln(ρ/a₁)/ln(ρ/a₂)); monotonicity of a stuck needle pushing into linear elastic tissue (every station
// moves forward or stays, so the force on it never falls); the invariants friction + tip = total and
// tip ≤ cutting force; and the voxel reference against a simplex model of the same uniform block
// (both discretise the same continuum problem, so they agree to discretisation error).
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <vim/image.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/vim.hpp>
#include <vim/voxel_statistics.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The prism 20 × 20 × 60 mm, E = 30 kPa, ν = 0.3, the four long faces held, a needle along its axis.
Scenario prism_scenario(const std::string& needle) {
  return parse_scenario_text(
      yaml(needle, "[]", "{youngs_modulus: 30, poisson_ratio: 0.3}",
           "[{type: fixed, region: {box_face: x_min}}, {type: fixed, region: {box_face: x_max}}, "
           "{type: fixed, region: {box_face: y_min}}, {type: fixed, region: {box_face: y_max}}]"),
      3);
}

double final_axial_force(const MeshModel<3>& mesh, const Scenario& sc, unsigned degree) {
  SimulationOptions o = quiet();
  o.degree = degree;
  return NeedleSimulation<3>(mesh, sc, o).run().needles.at(0).axial_force.back();
}

}  // namespace

// Antiplane theory: F ∝ 1/ln(ρ/a), so doubling the diameter from 1 to 2 mm in the 20 mm section raises
// the stuck needle's force by ln(ρ/0.5)/ln(ρ/1) = 1.291 (within 3%: measured 1.292 on the P2 mesh and
// 1.299 on the P1 one). A line of points gives the same force for every diameter. The absolute force is
// checked loosely against the antiplane integral 2πG ∫ U dz / ln(ρ/a) with U = d − z along the stuck
// shaft: the free entry face, the tissue the shaft drags ahead of the tip and the lateral coupling make
// the 3D force differ from it (7% below and 2% below it here).
TEST(NeedleBand, StuckNeedleForceFollowsAntiplaneTheoryInTheDiameter) {
  const std::string needle = "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 50, steps: 5, diameter: ";
  const double rho = 0.5394 * 20.0;
  const double ratio = std::log(rho / 0.5) / std::log(rho / 1.0);
  const double g = 30.0 / (2.0 * 1.3);
  const double antiplane = 2.0 * kPi * g * 0.5 * 50.0 * 50.0 / std::log(rho / 0.5);
  for (const auto& [n, degree] :
       {std::pair{std::array<int, 3>{{7, 7, 16}}, 2u}, std::pair{std::array<int, 3>{{11, 11, 31}}, 1u}}) {
    const MeshModel<3> prism = block(V3(-10, -10, 0), V3(10, 10, 60), n, [](const V3&) { return 30.0; });
    const double f1 =
        final_axial_force(prism, prism_scenario(needle + "1, friction: {model: stick}}"), degree);
    const double f2 =
        final_axial_force(prism, prism_scenario(needle + "2, friction: {model: stick}}"), degree);
    std::printf("%d nodes per side, P%u: forces %.1f / %.1f mN, ratio %.4f (antiplane %.4f)\n", n[0], degree,
                f1, f2, f2 / f1, ratio);
    EXPECT_NEAR(f2 / f1, ratio, 0.03 * ratio) << "P" << degree;
    EXPECT_NEAR(f1, antiplane, 0.15 * antiplane) << "P" << degree;
  }
}

// A stuck needle with cutting force 0 pushing into linear elastic tissue: the axial force never falls,
// on VIM and grid meshes, P1 and P2, the path off the mesh vertices.
TEST(NeedleBand, StuckNeedleForceNeverFalls) {
  const Image<3> img = block_image({{20, 20, 24}}, 60.0);
  const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{7, 7, 8}});
  VimOptions vo;
  vo.max_iterations = 6;
  const SimplexMesh<3> vim_mesh = optimize<3>(img, grid, vo).mesh;
  const Scenario sc = block_scenario(", friction: {model: stick}");
  for (const auto* which : {"grid", "vim"})
    for (unsigned degree : {1u, 2u}) {
      SimulationOptions o = quiet();
      o.degree = degree;
      const auto res = NeedleSimulation<3>(image_mesh(img, which[0] == 'g' ? grid : vim_mesh), sc, o).run();
      const auto& f = res.needles.at(0).axial_force;
      ASSERT_GT(f.back(), 0.0) << which << " P" << degree;
      for (std::size_t k = 1; k < f.size(); ++k)
        EXPECT_GE(f[k], f[k - 1] - 1e-9 * f.back()) << which << " P" << degree << " step " << k;
      for (const auto& w : res.warnings) EXPECT_EQ(w.find("falls"), std::string::npos) << w;
    }
}

// With a cutting force the tissue at the tip is pushed until its force reaches F_c: the tip force never
// exceeds F_c (and reaches it), friction + tip = the total axial force at every step, and under stick
// the friction part never falls; the same invariants under stick-slip.
TEST(NeedleBand, CuttingForceBoundsTheTipAndSplitsTheAxialForce) {
  const Image<3> img = block_image({{20, 20, 24}}, 20.0);
  const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{7, 7, 8}});
  const double fc = 40.0;
  for (const std::string friction : {"{model: stick}", "{model: stick-slip, max_shear_per_length: 20}"})
    for (unsigned degree : {1u, 2u}) {
      SimulationOptions o = quiet();
      o.degree = degree;
      const Scenario sc = block_scenario(", cutting_force: 40, friction: " + friction);
      const auto r = NeedleSimulation<3>(image_mesh(img, grid), sc, o).run().needles.at(0);
      const std::string at = friction + " P" + std::to_string(degree);
      double largest_tip = 0.0;
      for (std::size_t k = 0; k < r.axial_force.size(); ++k) {
        EXPECT_NEAR(r.friction_force[k] + r.tip_force[k], r.axial_force[k],
                    1e-9 * (1.0 + r.axial_force.back()))
            << at << " step " << k;
        EXPECT_LE(r.tip_force[k], fc * (1.0 + 1e-6)) << at << " step " << k;
        largest_tip = std::max(largest_tip, r.tip_force[k]);
        if (k > 0 && friction == "{model: stick}") {
          EXPECT_GE(r.friction_force[k], r.friction_force[k - 1] - 1e-9 * r.axial_force.back()) << at << k;
        }
      }
      EXPECT_GT(largest_tip, 0.99 * fc) << at;       // the cutting limit is reached
      EXPECT_GT(r.friction_force.back(), fc) << at;  // and the shaft carries force once cut
    }
}

// The voxel reference and a simplex model of the same uniform block use the same coupling (the same
// coupling radius and stations): their final forces agree within discretisation (measured 1.1% apart:
// 2073 and 2050 mN), where a line
// of points gives each mesh its own value (the force falls like 1/ln(1/h) with the element size h).
TEST(NeedleBand, VoxelReferenceAndSimplexModelAgree) {
  const Image<3> img = block_image({{20, 20, 24}}, 20.0);  // uniform: the inclusion has the same modulus
  const Scenario sc = block_scenario(", coupling_radius: 3, sample_spacing: 2, friction: {model: stick}");
  const auto voxel = NeedleSimulation<3>::voxel(img, WorldTransform<3>{}, sc, quiet()).run();
  const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{11, 11, 13}});
  SimulationOptions o = quiet();
  o.degree = 2;
  const auto simplex = NeedleSimulation<3>(image_mesh(img, grid), sc, o).run();
  const double fv = voxel.needles.at(0).axial_force.back(), fs = simplex.needles.at(0).axial_force.back();
  std::printf("voxel %.2f mN, simplex P2 %.2f mN\n", fv, fs);
  EXPECT_NEAR(fs, fv, 0.05 * fv);
}

// Targets near the shaft. Truth: antiplane shear of a rigid shaft of radius a in the held prism — the
// axial displacement at radius r is U·ln(ρ/r)/ln(ρ/a) (ρ = 0.5394·s), exact in 3D where U varies
// linearly along the stuck shaft (∇²(U(z) ln r) = 0), so its ratios at one depth do not depend on U. The
// targets at r = 0 (inside the needle: the tissue on its surface), a, 2a and 3a lie within the bands'
// effective radius, where the mesh holds only the band mean; one at 10a lies outside it, where the mesh
// value is the answer. Without the near-field reading the mesh's value on the axis is 40% low here.
TEST(NeedleBand, TargetsNearTheShaftFollowTheAntiplaneProfile) {
  const double a = 0.5, rho = 0.5394 * 20.0;
  const std::vector<double> r = {0.0, a, 2 * a, 3 * a, 10 * a};
  std::string targets = "[";
  for (std::size_t k = 0; k < r.size(); ++k)
    targets += (k ? ", " : "") + std::string("{name: t") + std::to_string(k) + ", position: [" +
               std::to_string(r[k] * 0.6) + ", " + std::to_string(r[k] * 0.8) + ", 25]}";
  const Scenario sc = parse_scenario_text(
      yaml("{entry: [0, 0, 0], direction: [0, 0, 1], depth: 50, steps: 5, diameter: 1, friction: {model: "
           "stick}}",
           targets + "]", "{youngs_modulus: 30, poisson_ratio: 0.3}",
           "[{type: fixed, region: {box_face: x_min}}, {type: fixed, region: {box_face: x_max}}, "
           "{type: fixed, region: {box_face: y_min}}, {type: fixed, region: {box_face: y_max}}]"),
      3);
  const MeshModel<3> prism =
      block(V3(-10, -10, 0), V3(10, 10, 60), {{7, 7, 16}}, [](const V3&) { return 30.0; });
  SimulationOptions o = quiet();
  o.degree = 2;
  const auto result = NeedleSimulation<3>(prism, sc, o).run();
  const auto& u = result.needles.at(0).target_displacement.back();
  const double u_surface = u[1].z();
  ASSERT_GT(u_surface, 1.0);
  EXPECT_NEAR(u[0].z(), u_surface, 1e-12);  // inside the needle: the tissue on its surface
  for (std::size_t k = 2; k < r.size(); ++k) {
    const double theory = std::log(rho / r[k]) / std::log(rho / a);
    std::printf("r = %.2f mm: u/u(a) = %.4f, antiplane %.4f\n", r[k], u[k].z() / u_surface, theory);
    EXPECT_NEAR(u[k].z() / u_surface, theory, 0.03) << "r = " << r[k];
  }
}

namespace {

// A slipping needle (stick-slip, a low limit: every station carries the same force per length whatever
// the band) 30 mm into the held prism (P2, h = 2 mm, cutting distance 1 mm) with the extra needle keys
// `band`; the target displacements at the last step, on the axis 1 and 4 mm ahead of the tip.
std::vector<V3> targets_ahead_of_a_slipping_needle(const std::string& band) {
  const Scenario sc = parse_scenario_text(
      yaml(
          "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 30, steps: 3, diameter: 1, cutting_distance: 1, " +
              band + ", friction: {model: stick-slip, max_shear_per_length: 2.0}}",
          "[{name: near, position: [0, 0, 31]}, {name: far, position: [0, 0, 34]}]",
          "{youngs_modulus: 30, poisson_ratio: 0.3}",
          "[{type: fixed, region: {box_face: x_min}}, {type: fixed, region: {box_face: x_max}}, "
          "{type: fixed, region: {box_face: y_min}}, {type: fixed, region: {box_face: y_max}}]"),
      3);
  const MeshModel<3> prism =
      block(V3(-10, -10, 0), V3(10, 10, 60), {{10, 10, 30}}, [](const V3&) { return 30.0; });
  SimulationOptions o = quiet();
  o.degree = 2;
  const auto result = NeedleSimulation<3>(prism, sc, o).run();
  const std::vector<V3> u = result.needles.at(0).target_displacement.back();
  std::printf("%s: 1 mm ahead %.5f, 4 mm ahead %.5f mm (axial force %.2f)\n", band.c_str(), u[0].z(),
              u[1].z(), result.needles.at(0).axial_force.back());
  return u;
}

}  // namespace

// Ahead of the end of the held shaft the mesh carries each station's force spread over its band (here
// a cylinder surface of radius R), while the tissue takes it on the needle's surface (radius a); the
// target reading adds the difference of the two loads' Kelvin fields (fem::band_load_displacement,
// checked against plane theory and the point force in the fem suite). Truth: the tissue's displacement
// does not depend on R, a choice of the model: read so, the targets agree for R = 2 and 4 mm; the mesh's
// own values do not.
TEST(NeedleBand, TargetsAheadOfTheHeldShaftDoNotDependOnTheBandRadius) {
  const auto u2 = targets_ahead_of_a_slipping_needle("sample_spacing: 2, coupling_radius: 2");
  const auto u4 = targets_ahead_of_a_slipping_needle("sample_spacing: 2, coupling_radius: 4");
  for (std::size_t k = 0; k < 2; ++k) EXPECT_NEAR(u4[k].z() / u2[k].z(), 1.0, 0.01) << "target " << k;
}

// The stations are a discretisation of the shaft: the station nearest the tip carries the friction of
// the shaft up to the tip, which its band spreads over the station's own length, up to one pitch behind
// the tip. Truth: the tissue's displacement does not depend on the station pitch, a choice of the model
// (the slipping needle loads the tissue with the same force per length along the same inserted shaft
// whatever the pitch): read with the Kelvin field of the load on the shaft it carries, the targets
// agree for stations of 1 and 3 mm.
TEST(NeedleBand, TargetsAheadOfTheTipDoNotDependOnTheStationPitch) {
  const auto u1 = targets_ahead_of_a_slipping_needle("coupling_radius: 2, sample_spacing: 1");
  const auto u3 = targets_ahead_of_a_slipping_needle("coupling_radius: 2, sample_spacing: 3");
  for (std::size_t k = 0; k < 2; ++k) EXPECT_NEAR(u3[k].z() / u1[k].z(), 1.0, 0.02) << "target " << k;
}

namespace {

// The block image's scenario with a needle at (x, y) along z and two targets at 8 mm depth: `near`
// `near_offset` from the axis, `far` 8 mm from it.
SimulationResult<3> band_run(const Image<3>& img, double x, double y, double near_offset) {
  const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{7, 7, 8}});
  std::ostringstream needle, targets;
  needle << "{entry: [" << x << ", " << y
         << ", 0], direction: [0, 0, 1], depth: 18, steps: 3, diameter: 1.27, "
         << "friction: {model: stick}}";
  targets << "[{name: near, position: [" << x + near_offset << ", " << y << ", 8]}, {name: far, position: ["
          << x << ", " << y + 8.0 << ", 8]}]";
  const Scenario sc = parse_scenario_text(
      yaml(needle.str(), targets.str(), "{youngs_modulus: image, poisson_ratio: 0.45}",
           "[{type: fixed, region: {box_face: z_max}}, {type: fixed, region: {box_face: x_min}}]"),
      3);
  SimulationOptions o = quiet();
  o.degree = 2;
  return NeedleSimulation<3>(image_mesh(img, grid), sc, o).run();
}

std::string band_warning_of(const SimulationResult<3>& r) {
  for (const auto& w : r.warnings)
    if (w.find("inside the band (radius") != std::string::npos) return w;
  return "";
}

}  // namespace

// A target within the band radius R of the shaft (R = the element size 3.33 mm at P2 on this grid)
// is named in the warning and in report.json's band.targets_inside; one 8 mm away is not, and with the
// near target 1.1 R from the axis there is no warning at all (uniform block: no modulus change).
TEST(NeedleBand, TargetsInsideTheBandRadiusAreWarnedAbout) {
  const Image<3> uniform = block_image({{20, 20, 24}}, 20.0);
  const SimulationResult<3> inside = band_run(uniform, 9.37, 10.29, 1.5);
  const double radius = inside.report["needles"][0]["band"]["radius"];
  ASSERT_GT(radius, 1.5);
  EXPECT_EQ(inside.report["needles"][0]["band"]["targets_inside"], nlohmann::json::array({"near"}));
  EXPECT_TRUE(inside.report["needles"][0]["band"]["modulus_changes"].empty());
  const std::string w = band_warning_of(inside);
  EXPECT_NE(w.find("lie targets: near;"), std::string::npos) << w;
  EXPECT_EQ(w.find("far"), std::string::npos) << w;
  EXPECT_EQ(w.find("modulus changes"), std::string::npos) << w;
  const SimulationResult<3> outside = band_run(uniform, 9.37, 10.29, 1.1 * radius);
  EXPECT_TRUE(outside.report["needles"][0]["band"]["targets_inside"].empty());
  EXPECT_EQ(band_warning_of(outside), "");
}

// A modulus change inside the bands, off the axis: a stiff sphere (60 against 20 kPa, radius 4 mm,
// centre (10, 10, 12)) 1.5 mm beside the needle's path, inside the band radius R = 3.36 mm, changes the
// modulus within the bands of the stations beside it by more than 20%, so the run warns and report.json
// lists those stations; a path 6.6 mm from the sphere (farther than R + an element) has none.
TEST(NeedleBand, ModulusChangesInsideTheBandAreWarnedAbout) {
  const Image<3> sphere = block_image({{20, 20, 24}}, 60.0);
  const SimulationResult<3> through = band_run(sphere, 15.5, 10.0, -6.0);
  const auto& changes = through.report["needles"][0]["band"]["modulus_changes"];
  ASSERT_FALSE(changes.empty());
  double largest = 0.0;
  for (const auto& c : changes) {
    EXPECT_LT(static_cast<double>(c["from"]), 16.0 + 1e-9);  // stations reaching the sphere (z 8 … 16)
    EXPECT_GT(static_cast<double>(c["to"]), 8.0 - 1e-9);
    largest = std::max(largest, static_cast<double>(c["relative_change"]));
  }
  EXPECT_GT(largest, 0.2);
  EXPECT_NE(band_warning_of(through).find("modulus changes above 20%"), std::string::npos)
      << band_warning_of(through);
  const SimulationResult<3> beside = band_run(sphere, 17.5, 2.5, -6.0);
  EXPECT_TRUE(beside.report["needles"][0]["band"]["modulus_changes"].empty());
  EXPECT_EQ(band_warning_of(beside), "");
}

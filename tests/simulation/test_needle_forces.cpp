// The needle's axial force through the whole simulation (3D, BandCoupling with the tip bearing in
// NeedleInsertion). Truths: Sneddon's rigid flat punch on an elastic half-space, F = 2aEδ/(1 − ν²)
// (so the force is linear in the indentation δ and in the radius a, and the tissue under a needle with
// cutting force F_c gives way at δ_p = F_c(1 − ν²)/(2aE)); the quasi-static cutting condition (while
// the tip cuts, its force is the cutting force); and monotonicity (with stick-slip friction and no
// cutting force, a needle pushed further into linear elastic tissue cannot pull less).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/vim.hpp>

#include "../fem/box_mesh.hpp"
#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

constexpr double kE = 30.0, kNu = 0.3;

// Node coordinates from 0 to `extent`: spacing h up to `core`, then growing by `ratio` per cell.
std::vector<double> graded(double h, double core, double extent, double ratio) {
  std::vector<double> x = {0.0};
  double step = h;
  while (x.back() < extent - 1e-9) {
    if (x.back() >= core - 1e-9) step *= ratio;
    x.push_back(std::min(extent, x.back() + step));
    if (extent - x.back() < 0.5 * step) x.back() = extent;
  }
  return x;
}

std::vector<double> symmetric(const std::vector<double>& half) {
  std::vector<double> x;
  for (auto it = half.rbegin(); it != half.rend(); ++it) x.push_back(-*it);
  for (std::size_t k = 1; k < half.size(); ++k) x.push_back(half[k]);
  return x;
}

// A uniform block [-32, 32]² × [0, 32] mm (50 needle radii each way), graded from element size h
// near the entry point (0, 0, 0) of the face z = 0.
MeshModel<3> punch_block(double h, double ratio) {
  const auto lateral = symmetric(graded(h, 2.0 * h, 32.0, ratio));
  MeshModel<3> m;
  m.mesh = test::kuhn_mesh<3>({{lateral, lateral, graded(h, 2.0 * h, 32.0, ratio)}});
  orient_positively(m.mesh);
  m.values.assign(m.mesh.n_cells(), ElementValue{1, kE, 0.0});
  return m;
}

// A needle pressed along z on the face z = 0, every other face held.
Scenario punch_scenario(double diameter, double depth, int steps, const std::string& extra) {
  std::ostringstream needle;
  needle << "{entry: [0, 0, 0], direction: [0, 0, 1], depth: " << depth << ", steps: " << steps
         << ", diameter: " << diameter << ", " << extra << "}";
  return parse_scenario_text(
      yaml(needle.str(), "[]", "{youngs_modulus: 30, poisson_ratio: 0.3}",
           "[{type: fixed, region: {box_face: x_min}}, {type: fixed, region: {box_face: x_max}}, "
           "{type: fixed, region: {box_face: y_min}}, {type: fixed, region: {box_face: y_max}}, "
           "{type: fixed, region: {box_face: z_max}}]"),
      3);
}

NeedleRun<3> run_needle(const MeshModel<3>& mesh, const Scenario& sc, unsigned degree) {
  SimulationOptions o = quiet();
  o.degree = degree;
  return NeedleSimulation<3>(mesh, sc, o).run().needles.at(0);
}

double punch_force(double a, double delta) { return 2.0 * a * kE * delta / (1.0 - kNu * kNu); }

}  // namespace

// Sneddon: a needle (a = 0.635 mm) pressed 0.1 … 0.5 mm on the face of the uniform block, cutting
// force too high to cut: the force at each step within 5% of 2aEδ/(1 − ν²), P2, on a mesh with h = 4 mm
// ≫ a near the tip (measured 1.0035) and one with h = 0.5 mm < a there (0.9511); on the coarse mesh a
// needle of twice the radius carries twice the force (within 3%; measured 2.007).
TEST(NeedleTip, FlatPunchForceOnTheFaceOfAUniformBlock) {
  for (const auto& [h, ratio] : {std::pair{4.0, 1.6}, std::pair{0.5, 1.8}}) {
    const MeshModel<3> mesh = punch_block(h, ratio);
    std::vector<double> last;
    for (const double a : h > 1.0 ? std::vector<double>{0.635, 1.27} : std::vector<double>{0.635}) {
      const auto r = run_needle(
          mesh, punch_scenario(2.0 * a, 0.5, 5, "cutting_force: 1.0e6, friction: {model: stick}"), 2);
      for (std::size_t k = 1; k < r.depth.size(); ++k) {
        const double theory = punch_force(a, r.depth[k]);
        std::printf("h %.2f a %.3f depth %.2f: force %.4f mN, punch %.4f (%.4f)\n", h, a, r.depth[k],
                    r.axial_force[k], theory, r.axial_force[k] / theory);
        EXPECT_NEAR(r.axial_force[k], theory, 0.05 * theory) << "h " << h << " a " << a << " step " << k;
        EXPECT_NEAR(r.tip_force[k], r.axial_force[k], 1e-9 * theory);  // no shaft station holds tissue
      }
      last.push_back(r.axial_force.back());
    }
    if (last.size() == 2) {
      EXPECT_NEAR(last[1] / last[0], 2.0, 0.03 * 2.0) << "h " << h;
    }
  }
}

// The needle with cutting force F_c = 20 mN: while it presses, its tip force grows linearly with the
// depth (the punch); it gives way at δ_p = F_c(1 − ν²)/(2aE) = 0.478 mm (within 5%, from the slope of
// the pressing steps), the run lists that one puncture, and from then on the tip part stays at F_c
// (within 2%) at every step while the friction part grows.
TEST(NeedleTip, PunctureAtTheCuttingForceThenCutsAtIt) {
  const double a = 0.635, fc = 20.0, delta_p = fc * (1.0 - kNu * kNu) / (2.0 * a * kE);
  const MeshModel<3> mesh = punch_block(4.0, 1.6);
  const auto r =
      run_needle(mesh,
                 punch_scenario(2.0 * a, 3.0, 30,
                                "cutting_force: 20, friction: {model: stick-slip, max_shear_per_length: 2}"),
                 2);
  std::size_t first_cut = 0;
  for (std::size_t k = 1; k < r.depth.size() && first_cut == 0; ++k)
    if (r.tip_cutting[k]) first_cut = k;
  ASSERT_GT(first_cut, 1u);
  const std::size_t k0 = first_cut - 1;  // the last pressing step
  const double slope = r.tip_force[k0] / r.depth[k0];
  std::printf("puncture between %.3f and %.3f mm, from the slope at %.4f mm (theory %.4f)\n", r.depth[k0],
              r.depth[first_cut], fc / slope, delta_p);
  EXPECT_NEAR(fc / slope, delta_p, 0.05 * delta_p);
  EXPECT_GT(fc / slope, r.depth[k0]);
  EXPECT_LE(fc / slope, r.depth[first_cut] + 1e-9);
  ASSERT_EQ(r.punctures.size(), 1u);
  EXPECT_DOUBLE_EQ(r.punctures[0].depth, r.depth[first_cut]);
  EXPECT_DOUBLE_EQ(r.punctures[0].force_before, r.axial_force[k0]);
  for (std::size_t k = first_cut; k < r.depth.size(); ++k) {
    EXPECT_EQ(r.tip_cutting[k], 1) << "step " << k;
    EXPECT_NEAR(r.tip_force[k], fc, 0.02 * fc) << "step " << k;
    EXPECT_NEAR(r.friction_force[k] + r.tip_force[k], r.axial_force[k], 1e-9 * r.axial_force[k]);
    if (k > first_cut) {
      EXPECT_GE(r.friction_force[k], r.friction_force[k - 1]) << "step " << k;
    }
  }
  EXPECT_GT(r.friction_force.back(), 0.0);
}

// Stick-slip with no cutting force in a block with a stiffer sphere: no step's axial force below the
// previous one's (beyond 1e-9 relative), P1 and P2 on a VIM mesh and on the grid it started from, and
// the voxel reference; the path off the mesh vertices; friction from the first step on.
TEST(NeedleTip, StickSlipForceNeverFallsWithoutCuttingForce) {
  const Image<3> img = block_image({{20, 20, 24}}, 60.0);
  const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), {{7, 7, 8}});
  VimOptions vo;
  vo.max_iterations = 6;
  const SimplexMesh<3> vim_mesh = optimize<3>(img, grid, vo).mesh;
  const Scenario sc = block_scenario(", friction: {model: stick-slip, max_shear_per_length: 3}");
  const auto check = [](const NeedleRun<3>& r, const std::string& at) {
    const auto& f = r.axial_force;
    ASSERT_GT(f.back(), 0.0) << at;
    EXPECT_GT(f[1], 0.0) << at;  // the first step already carries friction
    for (std::size_t k = 1; k < f.size(); ++k)
      EXPECT_GE(f[k], f[k - 1] - 1e-9 * std::abs(f[k - 1])) << at << " step " << k;
  };
  for (const auto* which : {"grid", "vim"})
    for (unsigned degree : {1u, 2u}) {
      SimulationOptions o = quiet();
      o.degree = degree;
      const auto res = NeedleSimulation<3>(image_mesh(img, which[0] == 'g' ? grid : vim_mesh), sc, o).run();
      check(res.needles.at(0), std::string(which) + " P" + std::to_string(degree));
    }
  check(NeedleSimulation<3>::voxel(img, WorldTransform<3>{}, sc, quiet()).run().needles.at(0), "voxel");
}

// The shaft's near field, which the mesh does not resolve: a station sliding at the stick-slip limit q
// carries q per length, so the antiplane annulus around the needle has on its surface the principal
// strain q/(4πGa) and exceeds the small-strain limit 0.1 within r = q/(4πG·0.1) of the axis, whatever
// the mesh (q = 20 mN/mm, G = 11.54 kPa, a = 0.635 mm: 0.217 and 1.379 mm). max_strain includes it;
// a target 0.5 mm from the inserted shaft lies in it, one 3 mm away and one ahead of the tip do not,
// and the warning names the radius and that target.
TEST(NeedleTip, NearFieldStrainOfSlidingStationsIsTheAntiplaneSurfaceStrain) {
  const double a = 0.635, q = 20.0, pi = 3.14159265358979323846;
  const double g = kE / (2.0 * (1.0 + kNu)), surface = q / (4.0 * pi * g * a),
               radius = q / (4.0 * pi * g * 0.1);
  const Scenario sc = parse_scenario_text(
      yaml("{entry: [0, 0, 0], direction: [0, 0, 1], depth: 10, steps: 10, diameter: 1.27, "
           "friction: {model: stick-slip, max_shear_per_length: 20}}",
           "[{name: near, position: [0.5, 0, 5]}, {name: far, position: [3, 0, 5]}, "
           "{name: ahead, position: [0.5, 0, 15]}]",
           "{youngs_modulus: 30, poisson_ratio: 0.3}",
           "[{type: fixed, region: {box_face: x_min}}, {type: fixed, region: {box_face: x_max}}, "
           "{type: fixed, region: {box_face: y_min}}, {type: fixed, region: {box_face: y_max}}, "
           "{type: fixed, region: {box_face: z_max}}]"),
      3);
  SimulationOptions o = quiet();
  o.degree = 1;
  const auto res = NeedleSimulation<3>(punch_block(4.0, 1.6), sc, o).run();
  const NeedleRun<3>& r = res.needles.at(0);
  ASSERT_EQ(r.near_field_strain.size(), r.depth.size());
  for (std::size_t k = 0; k < r.depth.size(); ++k) {
    EXPECT_LE(r.near_field_strain[k], surface * (1.0 + 1e-9)) << "step " << k;  // F′ ≤ q
    EXPECT_GE(r.max_strain[k], r.near_field_strain[k]) << "step " << k;
  }
  EXPECT_NEAR(r.near_field_strain.back(), surface, 1e-9 * surface);
  EXPECT_NEAR(r.small_strain_radius.back(), radius, 1e-9 * radius);
  EXPECT_NEAR(r.max_strain.back(), std::max(surface, r.mesh_strain.back()), 1e-12);
  EXPECT_EQ(r.target_in_near_field.back(), (std::vector<int>{1, 0, 0}));
  EXPECT_EQ(r.target_in_near_field[4], (std::vector<int>{0, 0, 0}));  // the tip has not reached z = 5
  bool warned = false;
  for (const auto& w : res.warnings)
    warned = warned || (w.find("next to the shaft") != std::string::npos &&
                        w.find("targets in it: near (from step") != std::string::npos &&
                        w.find("far") == std::string::npos);
  EXPECT_TRUE(warned);
}

namespace {

// The largest change of a per-step curve between two runs, over the largest magnitude of the finer
// run: max_k |X_coarse(d_k) − X_fine(d_k)| / max_k |X_fine|, the finer curve read at the coarser
// run's depths d_k (linear in the depth between its steps).
template <class Value, class Norm>
double curve_change(const std::vector<double>& depth, const std::vector<Value>& coarse,
                    const std::vector<double>& fine_depth, const std::vector<Value>& fine, Norm norm) {
  double change = 0.0, scale = 0.0;
  for (const auto& x : fine) scale = std::max(scale, norm(x));
  for (std::size_t k = 0; k < depth.size(); ++k) {
    const auto hi = std::lower_bound(fine_depth.begin(), fine_depth.end(), depth[k] - 1e-12);
    const std::size_t j = static_cast<std::size_t>(hi - fine_depth.begin());
    Value at = fine[std::min(j, fine.size() - 1)];
    if (j > 0 && j < fine.size() && fine_depth[j] > depth[k] + 1e-12) {
      const double t = (depth[k] - fine_depth[j - 1]) / (fine_depth[j] - fine_depth[j - 1]);
      at = (1.0 - t) * fine[j - 1] + t * fine[j];
    }
    change = std::max(change, norm(coarse[k] - at));
  }
  return scale > 0.0 ? change / scale : change;
}

struct CurveChanges {
  double force = 0.0;
  std::vector<double> targets;
};

CurveChanges curve_changes(const NeedleRun<3>& coarse, const NeedleRun<3>& fine) {
  CurveChanges c;
  c.force = curve_change(coarse.depth, coarse.axial_force, fine.depth, fine.axial_force,
                         [](double x) { return std::abs(x); });
  for (std::size_t t = 0; t < fine.target_displacement.front().size(); ++t) {
    std::vector<V3> uc, uf;
    for (const auto& u : coarse.target_displacement) uc.push_back(u[t]);
    for (const auto& u : fine.target_displacement) uf.push_back(u[t]);
    c.targets.push_back(curve_change(coarse.depth, uc, fine.depth, uf, [](const V3& x) { return x.norm(); }));
  }
  return c;
}

// A uniform block image (20 × 20 × 24 voxels of 1 mm, 20 kPa), the needle along z off the mesh
// vertices with stick-slip friction and a cutting force, three targets: beside the path, off it and
// ahead of the final tip.
// `tissues`: a needle.tissues entry list (empty: none).
Scenario convergence_scenario(int steps, const std::string& tissues = "") {
  std::ostringstream needle;
  needle << "{entry: [9.37, 10.29, 0], direction: [0, 0, 1], depth: 16, steps: " << steps
         << ", diameter: 1.27, cutting_force: 8, friction: {model: stick-slip, max_shear_per_length: 3}"
         << (tissues.empty() ? "" : ", tissues: " + tissues) << "}";
  return parse_scenario_text(
      yaml(needle.str(),
           "[{name: beside, position: [12.6, 10.29, 8]}, {name: off, position: [14.0, 12.0, 10]}, "
           "{name: ahead, position: [9.37, 10.29, 19]}, {name: in_band, position: [10.9, 10.29, 8]}]",
           "{youngs_modulus: image, poisson_ratio: 0.45}",
           "[{type: fixed, region: {box_face: z_max}}, {type: fixed, region: {box_face: x_min}}]"),
      3);
}

}  // namespace

// Curve convergence on a uniform block (P2): the whole force–depth curve and every target's trajectory
// change by at most 3% of their largest value between the two finest of three grids (element size
// 4, 2.86 and 2 mm), and between 16 and 32 steps of the same insertion on the finest grid.
TEST(NeedleTip, ForceCurveAndTargetTrajectoriesConvergeOnAUniformBlock) {
  const Image<3> img = block_image({{20, 20, 24}}, 20.0);  // the sphere has the block's modulus
  SimulationOptions o = quiet();
  o.degree = 2;
  std::vector<NeedleRun<3>> runs;
  const std::vector<std::array<int, 3>> grids = {{{8, 8, 9}}, {{11, 11, 13}}, {{15, 15, 18}}};
  for (const auto& n : grids) {
    const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), n);
    runs.push_back(
        NeedleSimulation<3>(image_mesh(img, grid), convergence_scenario(16), o).run().needles.at(0));
  }
  const SimplexMesh<3> mid = regular_grid_mesh<3>(img.box_min(), img.box_max(), grids[1]);
  const NeedleRun<3> twice =
      NeedleSimulation<3>(image_mesh(img, mid), convergence_scenario(32), o).run().needles.at(0);
  const auto print = [](const char* what, const CurveChanges& c) {
    std::printf("%s: force %.4f, targets", what, c.force);
    for (double t : c.targets) std::printf(" %.4f", t);
    std::printf("\n");
  };
  print("coarse vs mid", curve_changes(runs[0], runs[1]));
  const CurveChanges mesh = curve_changes(runs[1], runs[2]), steps = curve_changes(runs[1], twice);
  print("mid vs fine", mesh);
  print("16 vs 32 steps", steps);
  std::printf("final force %.4f / %.4f / %.4f / %.4f mN\n", runs[0].axial_force.back(),
              runs[1].axial_force.back(), runs[2].axial_force.back(), twice.axial_force.back());
  if (std::getenv("VIM_PRINT_CURVES"))
    for (const NeedleRun<3>* r : std::vector<const NeedleRun<3>*>{&runs[0], &runs[1], &runs[2], &twice})
      for (std::size_t k = 0; k < r->depth.size(); ++k)
        std::printf("%zu %6.2f F %8.4f tip %8.4f cut %d beside %8.5f off %8.5f ahead %8.5f\n",
                    r->depth.size(), r->depth[k], r->axial_force[k], r->tip_force[k], r->tip_cutting[k],
                    r->target_displacement[k][0].norm(), r->target_displacement[k][1].norm(),
                    r->target_displacement[k][2].norm());
  for (const CurveChanges* c : {&mesh, &steps}) {
    EXPECT_LE(c->force, 0.03);
    for (std::size_t t = 0; t < 3; ++t) EXPECT_LE(c->targets[t], 0.03) << "target " << t;
  }
}

// The same block with two tissues along the path: from z = 7.3 (between the stations and grid planes
// of both meshes) q = 12 instead of 3 and a cutting force of 20 instead of 8 (a box region). The force
// curve changes by at most 3% of its largest value between the two finer grids of the test above, and
// between 16 and 32 steps on the middle one (the stations do not carry tissue the tip has not cut
// while it presses the tissue of the higher cutting force): a
// station across z = 7.3 takes the integral of q over the shaft it carries, and the tip the cutting
// force of the tissue at the front, so neither jump moves with the stations or the tip disks. With q
// sampled at each station's centre the curve moves by about (12 − 3) mN/mm × the distance from the
// centre of the station across z = 7.3 to it between the grids.
TEST(NeedleTip, ForceCurveConvergesAcrossATissueBoundary) {
  const Image<3> img = block_image({{20, 20, 24}}, 20.0);
  const std::string tissues =
      "[{region: {box: {min: [-1, -1, 7.3], max: [21, 21, 25]}}, max_shear_per_length: 12, cutting_force: "
      "20}]";
  SimulationOptions o = quiet();
  o.degree = 2;
  const auto run = [&](const std::array<int, 3>& n, int steps) {
    const SimplexMesh<3> grid = regular_grid_mesh<3>(img.box_min(), img.box_max(), n);
    return NeedleSimulation<3>(image_mesh(img, grid), convergence_scenario(steps, tissues), o)
        .run()
        .needles.at(0);
  };
  const NeedleRun<3> mid = run({{11, 11, 13}}, 16), fine = run({{15, 15, 18}}, 16),
                     twice = run({{11, 11, 13}}, 32);
  const auto abs = [](double x) { return std::abs(x); };
  const double mesh = curve_change(mid.depth, mid.axial_force, fine.depth, fine.axial_force, abs);
  const double steps = curve_change(mid.depth, mid.axial_force, twice.depth, twice.axial_force, abs);
  std::printf("mid vs fine %.4f, 16 vs 32 steps %.4f; final force %.4f / %.4f / %.4f mN\n", mesh, steps,
              mid.axial_force.back(), fine.axial_force.back(), twice.axial_force.back());
  EXPECT_LE(mesh, 0.03);
  EXPECT_LE(steps, 0.03);
  // The deep tissue counts: its q and cutting force lift the final force well above the one-tissue run's.
  EXPECT_GT(fine.axial_force.back(), 20.0 + 3.0 * 7.3 + 12.0 * 5.0);
}

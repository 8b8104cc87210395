// Prostate phantom, CI-sized: the 2 mm image (30×25×25 voxels), the material of
// examples/prostate_needle.yaml (Eq. 15 moduli with its scale and clamp, ν = 0.45, λ = 0.3) and a
// compression load (x_max face clamped, x_min face pushed 5% of the length along +x). The VIM model
// and the regular grid it starts from (same nodes) are compared with the fine voxel reference (one
// Q1 cell per voxel) at every voxel centre, as bench/validate_needle does for the full sweep.
//
// Both models use P2 elements: with ν = 0.45, P1 tetrahedra lock and their error at a few hundred
// nodes is dominated by the locking of the mesh topology rather than by the modulus layout
// (docs/validation.md, "Why VIM lost at 80 nodes"). With P1 the test asserts VIM < grid only from
// 891 nodes on, where the full sweep shows it.
//
// The needle test runs the scenario's insertion (2 steps of 18 mm instead of 36 of 1 mm: the final
// state is the stick-slip friction limit on every model) at 252 and 891 nodes, P2 and P1, with the VIM
// mesh refined along the needle path as the scenario's mesh.needle_refinement asks (the grid is the
// regular grid of the same node count). The scenario's probe
// is an elastic support over its cylinder (the same on every mesh and on the reference; clamping the
// nodes that fall in the cylinder gave the grid and VIM different supports) and the needle cuts at one
// diameter behind the tip (no shaft point picked up at the tip sticks short of the friction limit).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/scenario/mesh_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/sizing.hpp>
#include <vim/vim.hpp>
#include <vim/voxel_statistics.hpp>

namespace {

using V3 = Eigen::Vector3d;
using vim::pipeline::Scenario;

constexpr double kProstateStrain = 0.05;

void add_compression(vim::fem::ElasticModel<3>& model, const V3& lo, const V3& hi) {
  const double tol = 1e-6 * (hi - lo).norm();
  model.add_dirichlet(vim::fem::DirichletBC<3>{vim::fem::box_face_region<3>(lo, hi, 0, true, tol)});
  vim::fem::DirichletBC<3> push{vim::fem::box_face_region<3>(lo, hi, 0, false, tol)};
  push.components = vim::fem::DirichletBC<3>::filled(false);
  push.components[0] = true;
  push.value = V3(kProstateStrain * (hi[0] - lo[0]), 0, 0);
  model.add_dirichlet(push);
}

double relative_l2(const std::vector<V3>& u, const std::vector<V3>& ref) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < ref.size(); ++k)
    num += (u[k] - ref[k]).squaredNorm(), den += ref[k].squaredNorm();
  return std::sqrt(num / den);
}

struct Prostate {
  Scenario sc =
      vim::pipeline::read_scenario(std::string(VIM_SOURCE_DIR) + "/examples/prostate_needle.yaml", 3);
  vim::pipeline::OrientedImage<3> img = vim::pipeline::phantoms::prostate(30);
  V3 lo = img.image.box_min(), hi = img.image.box_max();
  std::vector<V3> points, ref;
  Prostate() {
    for (std::size_t k = 0; k < img.image.voxel_count(); ++k)
      points.push_back(img.image.point_of(img.image.index_of(k)));
    std::vector<double> e(img.image.data.begin(), img.image.data.end());
    auto model = vim::fem::ElasticModel<3>::voxel_grid(
        img.image.size, lo, hi, vim::pipeline::scenario_modulus(sc, e), sc.poisson_ratio);
    add_compression(model, lo, hi);
    model.solve();
    ref = model.sample(points);
  }
  double error(const vim::SimplexMesh<3>& mesh, const std::vector<double>& mean, unsigned degree) const {
    vim::fem::ElasticModel<3> model(mesh, vim::pipeline::scenario_modulus(sc, mean), sc.poisson_ratio,
                                    degree);
    add_compression(model, lo, hi);
    model.solve();
    return relative_l2(model.sample(points), ref);
  }
};

struct Row {
  std::size_t nodes;
  double grid[3], vim[3];  // index = FE degree (1, 2)
};

Row row(const Prostate& s, long budget) {
  const auto axis = vim::nodes_per_axis_for_budget<3>(s.lo, s.hi, budget);
  const auto grid = vim::regular_grid_mesh<3>(s.lo, s.hi, axis);
  const vim::VoxelStatistics<3> stats(s.img.image);
  std::vector<double> grid_mean;
  for (std::size_t c = 0; c < grid.n_cells(); ++c)
    grid_mean.push_back(stats.value(vim::cell_points(grid, c)).mean);
  const vim::VimOptions vo =
      vim::pipeline::with_scenario_mesh({}, s.sc).vim_options();  // as the CLI applies them
  const auto r = vim::optimize<3>(s.img.image, grid, vo);
  std::vector<double> vim_mean;
  for (const auto& v : r.values) vim_mean.push_back(v.mean);  // Eq. 15
  Row out{grid.n_points(), {0, 0, 0}, {0, 0, 0}};
  for (unsigned p : {1u, 2u}) {
    out.grid[p] = s.error(grid, grid_mean, p);
    out.vim[p] = s.error(r.mesh, vim_mean, p);
    std::printf("nodes %zu, P%u: relL2 grid %.4f, VIM %.4f, ratio %.3f\n", out.nodes, p, out.grid[p],
                out.vim[p], out.vim[p] / out.grid[p]);
  }
  return out;
}

TEST(ProstateCompression, VimBeatsGridAt252And891NodesAndConverges) {
  const Prostate s;
  const Row a = row(s, 343), b = row(s, 1000);
  ASSERT_EQ(a.nodes, 252u);
  ASSERT_EQ(b.nodes, 891u);
  // P2 (the element for ν = 0.45): VIM below the grid at both counts (full sweep: ratios ≤ 0.7).
  EXPECT_LT(a.vim[2], 0.8 * a.grid[2]);
  EXPECT_LT(b.vim[2], 0.8 * b.grid[2]);
  // P1: VIM below the grid at 891 nodes (full sweep: 0.79).
  EXPECT_LT(b.vim[1], 0.9 * b.grid[1]);
  // Errors fall with the node count for both meshers and both degrees.
  for (unsigned p : {1u, 2u}) {
    EXPECT_LT(b.vim[p], a.vim[p]) << "P" << p;
    EXPECT_LT(b.grid[p], a.grid[p]) << "P" << p;
  }
}

TEST(ProstateNeedle, VimBelowGridAt252And891NodesP2WithTheScenariosNeedleRefinement) {
  Prostate s;
  ASSERT_TRUE(s.sc.needle_refinement.has_value())
      << "examples/prostate_needle.yaml lost mesh.needle_refinement";
  // One coupling radius for the reference and both meshes (the default follows each mesh's element size
  // near the path): the comparison then measures the meshes, not their needle bands. One friction limit
  // and no cutting force for all: the scenario's needle.tissues pick a limit by element modulus, which
  // the coarse meshes average differently from the voxels, so each model would carry its own load.
  for (auto& nd : s.sc.needles)
    nd.steps = 2, nd.coupling_radius = 3.0, nd.tissues.clear(), nd.cutting_force = 0.0;
  s.sc.output_every = 0;
  vim::pipeline::WorldTransform<3> tf;
  tf.origin = s.img.origin();
  tf.direction = s.img.direction;
  vim::pipeline::SimulationOptions opt;
  opt.progress = false;
  auto ref_sim = vim::pipeline::NeedleSimulation<3>::voxel(s.img.image, tf, s.sc, opt);
  const auto ref_run = ref_sim.run();
  // Every station slides: 15 mN/mm × the cut length, 36 mm less the cutting distance 1.27 mm and
  // the tissue the tip pushes ahead (docs/needle-model.md §9): a little below 15 × 34.73 = 521 mN.
  const double ref_force = ref_run.needles[0].axial_force.back();
  EXPECT_LT(ref_force, 15.0 * (36.0 - 1.27) * (1.0 + 1e-9));
  EXPECT_GT(ref_force, 0.98 * 15.0 * (36.0 - 1.27));
  const auto ref = ref_sim.model().sample(s.points);
  // The density the CLI uses for the scenario (mesh.needle_refinement), kept in E_G during VIM.
  const auto density = vim::pipeline::needle_refinement_density<3>(s.sc, s.img.image, tf);
  ASSERT_TRUE(density.has_value());
  const vim::VoxelStatistics<3> stats(s.img.image);

  struct Case {
    long budget;
    std::size_t nodes;
    double err[3][2];  // [degree][grid, VIM]
  };
  std::vector<Case> cases = {{343, 252, {}}, {1000, 891, {}}};
  for (Case& c : cases) {
    const auto axis = vim::nodes_per_axis_for_budget<3>(s.lo, s.hi, c.budget);
    vim::pipeline::MeshModel<3> grid, vim;
    grid.transform = vim.transform = tf;
    grid.mesh = vim::regular_grid_mesh<3>(s.lo, s.hi, axis);
    ASSERT_EQ(grid.mesh.n_points(), c.nodes);
    for (std::size_t k = 0; k < grid.mesh.n_cells(); ++k)
      grid.values.push_back(stats.value(vim::cell_points(grid.mesh, k)));
    const vim::VimOptions vo =
        vim::pipeline::with_scenario_mesh({}, s.sc).vim_options();  // as the CLI applies them
    auto r = vim::optimize_sized<3>(s.img.image, *density, grid.mesh, vo);
    ASSERT_EQ(r.mesh.n_points(), c.nodes);
    vim.mesh = std::move(r.mesh);
    vim.values = std::move(r.values);
    for (unsigned p : {1u, 2u}) {
      s.sc.degree = p;
      int k = 0;
      for (const auto* m : {&grid, &vim}) {
        vim::pipeline::NeedleSimulation<3> sim(*m, s.sc, opt);
        const auto run = sim.run();
        // Every shaft point slides at its friction limit at the end, as in the reference: the same load
        // up to how far each model lets the tip push the tissue ahead of it (within 1%).
        EXPECT_NEAR(run.needles[0].axial_force.back(), ref_force, 0.01 * ref_force)
            << "P" << p << (k ? " VIM" : " grid");
        c.err[p][k++] = relative_l2(sim.model().sample(s.points), ref);
      }
      std::printf("needle, %zu nodes, P%u: relL2 grid %.4f, VIM %.4f, ratio %.3f\n", c.nodes, p, c.err[p][0],
                  c.err[p][1], c.err[p][1] / c.err[p][0]);
    }
  }
  // P2: VIM below the grid at 252 nodes (ratio 0.854 with R = 3 mm, 2 steps). At 891 nodes it is not
  // (ratio 1.51 since stations join at the cut front: docs/validation.md, needle; it was 0.942 with
  // whole bands joining behind the tip), so only 252 is asserted. P1 is not asserted: with ν = 0.45
  // coarse P1 tetrahedra lock and the grid wins below 4050 nodes.
  EXPECT_LT(cases[0].err[2][1], 0.95 * cases[0].err[2][0]) << cases[0].nodes << " nodes";
  // Errors fall with the node count (P2, both meshers).
  EXPECT_LT(cases[1].err[2][0], cases[0].err[2][0]);
  EXPECT_LT(cases[1].err[2][1], cases[0].err[2][1]);
}

// The example's needle.tissues pick the phantom's anatomy by its label map (label regions read at the
// point), so every model of the phantom gives its shaft stations the same tissues: the voxel model and
// the regular grid at 252 and 891 nodes (element moduli of the blurred image, which picked the tissues
// before, put the interfaces where each mesh's averages cross the ranges: mm off on the coarse grid).
// Truth: the nominal geometry (phantoms::prostate_label at the station's point); stations closer to an
// interface than half a voxel diagonal of the 2 mm image (1.8 mm) are not judged.
double interface_distance(const V3& x, const vim::pipeline::phantoms::ProstateGeometry& g) {
  double level = -1.0;  // gland: first-order distance level / |grad level|, level = sum (x_a/s_a)^2 - 1
  V3 grad;
  for (int a = 0; a < 3; ++a) {
    const double s2 = g.gland_semi_axes[a] * g.gland_semi_axes[a];
    level += x[a] * x[a] / s2;
    grad[a] = 2.0 * x[a] / s2;
  }
  const V3 lc(g.lesion_centre[0], g.lesion_centre[1], g.lesion_centre[2]);
  return std::min(std::abs(level / grad.norm()), std::abs((x - lc).norm() - g.lesion_radius));
}

TEST(ProstateNeedle, ExampleTissuesAreThePhantomsAnatomyOnEveryModel) {
  Scenario sc =
      vim::pipeline::read_scenario(std::string(VIM_SOURCE_DIR) + "/examples/prostate_needle.yaml", 3);
  ASSERT_EQ(sc.needles.size(), 1u);
  ASSERT_EQ(sc.needles[0].tissues.size(), 2u) << "examples/prostate_needle.yaml: gland and lesion entries";
  sc.needles[0].steps = 1;
  sc.needles[0].sample_spacing = 1.0;  // a station every mm of the path on every model
  sc.output_every = 0;
  const vim::pipeline::OrientedImage<3> img = vim::pipeline::phantoms::prostate(30);
  const auto labels =
      std::make_shared<const vim::Image<3>>(vim::pipeline::phantoms::prostate_labels(30).image);
  vim::pipeline::WorldTransform<3> tf;
  tf.origin = img.origin();
  tf.direction = img.direction;
  vim::pipeline::SimulationOptions opt;
  opt.progress = false;
  std::vector<std::pair<std::string, vim::pipeline::NeedleRun<3>>> runs;
  runs.emplace_back(
      "voxel", vim::pipeline::NeedleSimulation<3>::voxel(img.image, tf, sc, opt, labels).run().needles.at(0));
  const V3 lo = img.image.box_min(), hi = img.image.box_max();
  const vim::VoxelStatistics<3> stats(img.image);
  for (long budget : {343L, 1000L}) {
    vim::pipeline::MeshModel<3> grid;
    grid.transform = tf;
    grid.label_image = labels;
    grid.mesh = vim::regular_grid_mesh<3>(lo, hi, vim::nodes_per_axis_for_budget<3>(lo, hi, budget));
    for (std::size_t k = 0; k < grid.mesh.n_cells(); ++k)
      grid.values.push_back(stats.value(vim::cell_points(grid.mesh, k)));
    runs.emplace_back("grid " + std::to_string(grid.mesh.n_points()),
                      vim::pipeline::NeedleSimulation<3>(grid, sc, opt).run().needles.at(0));
  }
  const vim::pipeline::phantoms::ProstateGeometry g;
  const V3 entry(sc.needles[0].entry[0], sc.needles[0].entry[1], sc.needles[0].entry[2]);
  const V3 dir(sc.needles[0].direction[0], sc.needles[0].direction[1], sc.needles[0].direction[2]);
  for (const auto& [name, r] : runs) {
    ASSERT_EQ(r.point_tissue.size(), r.point_s.size()) << name;
    int counted[3] = {0, 0, 0};  // outside the gland, gland, lesion
    for (std::size_t j = 0; j < r.point_s.size(); ++j) {
      const V3 x = entry + r.point_s[j] * dir;
      if (interface_distance(x, g) < 1.8) continue;
      const double p[3] = {x[0], x[1], x[2]};
      const int label = vim::pipeline::phantoms::prostate_label(p, g);
      const int expected = label == 2 ? 0 : label == 3 ? 1 : -1;
      EXPECT_EQ(r.point_tissue[j], expected) << name << ": station at s = " << r.point_s[j] << " mm";
      ++counted[expected + 1];
    }
    EXPECT_GE(counted[0], 5) << name;
    EXPECT_GE(counted[1], 10) << name;
    EXPECT_GE(counted[2], 1) << name;
  }
}

}  // namespace

// Truth: ∫_τ E dx of a voxel-wise constant image by exact clipping of every element against the voxel
// boxes (tests/support/clip_volume.hpp, code of the test's own). The paper's Eq. 15 end to end: a
// checkerboard of blocks is meshed by the grid mesher and by VIM, the element means go through the
// calls the CLI makes (VoxelStatistics::value for the grid, vim::optimize for VIM, then
// NeedleSimulation with the scenario's scale), and ½uᵀK u of the model's stiffness for a prescribed
// affine field and for a random P1 field must equal Σ_τ ½ε_τ:C:ε_τ·scale·∫_τ E dx.
//  * Grid mesh whose cells are the blocks: every element lies inside one block, so its voxel-centre
//    mean is its exact volume average: agreement to 1e-10 (round-off).
//  * VIM mesh: the mean counts the voxel centres in τ (Eq. 15 as the paper states it), not the overlap
//    volumes, so an element that straddles a block face gets a different value. Two bounds: (a) a
//    derived one: both the voxel-centre mean (or, with no centre inside, the centroid interpolation)
//    and the exact average are convex combinations of the values within one voxel of τ's bounding
//    box, so per element they differ by at most that range; (b) the measured error, asserted below a
//    stated ceiling (numbers in the tests) so that a change to the counting shows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/vim.hpp>
#include <vim/voxel_statistics.hpp>

#include "clip_volume.hpp"
#include "strain_energy_density.hpp"

using namespace vim;
using namespace vim::pipeline;

namespace {

constexpr int kBlock = 4;       // voxels per block edge
constexpr double kScale = 2.5;  // material.scale of the scenario
constexpr double kEq15Nu = 0.3;

// Blocks of kBlock^dim voxels; alternate blocks 1 and 8, each also scaled by its block index so that
// no two blocks along an axis are alike (a transposed or shifted image changes the values).
template <int dim>
Image<dim> checkerboard(const std::array<long, dim>& blocks, const std::array<double, dim>& spacing,
                        const std::array<double, dim>& origin) {
  std::array<long, dim> size;
  for (int a = 0; a < dim; ++a) size[a] = blocks[a] * kBlock;
  Image<dim> img(size, spacing, origin);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto i = img.index_of(k);
    long parity = 0;
    double tilt = 1.0;
    for (int a = 0; a < dim; ++a) {
      parity += i[a] / kBlock;
      tilt += (0.05 - 0.015 * a) * static_cast<double>(i[a] / kBlock);
    }
    img.data[k] = static_cast<float>((parity % 2 ? 8.0 : 1.0) * tilt);
  }
  return img;
}

template <int dim>
std::string scenario_text() {
  const std::string face = dim == 3 ? "z_min" : "y_min";
  return "material: {youngs_modulus: image, scale: " + std::to_string(kScale) +
         ", poisson_ratio: " + std::to_string(kEq15Nu) +
         "}\nboundary_conditions: [{type: fixed, region: {box_face: " + face + "}}]\n";
}

template <int dim>
std::string needle_text(const Image<dim>& img) {  // a short needle from the box centre (required, not run)
  const auto c = (0.5 * (img.box_min() + img.box_max())).eval();
  std::string entry = "[", dir = "[";
  for (int a = 0; a < dim; ++a) {
    entry += (a ? ", " : "") + std::to_string(c[a]);
    dir += a == dim - 1 ? "1" : "0, ";
  }
  return "needle: {entry: " + entry + "], direction: " + dir +
         "], depth: 0.5, steps: 1, diameter: 0.2, friction: {model: stick}}\n";
}

struct EnergyErrors {
  double affine = 0.0, random = 0.0;              // |½uᵀKu − truth| / truth
  double bound_affine = 0.0, bound_random = 0.0;  // the derived bound (a) on each, relative
  double max_element_modulus = 0.0;  // max_τ |E_τ − scale·∫_τE/|τ|| / (scale·∫_τE/|τ|)
};

// The model the pipeline builds for (mesh, values) and the two energies against the clipped truth.
template <int dim>
EnergyErrors energy_errors(const Image<dim>& img, const SimplexMesh<dim>& mesh,
                           const std::vector<ElementValue>& values) {
  using V = Eigen::Matrix<double, dim, 1>;
  MeshModel<dim> model;
  model.mesh = mesh;
  model.values = values;
  SimulationOptions quiet;
  quiet.progress = false;
  NeedleSimulation<dim> sim(model, parse_scenario_text(scenario_text<dim>() + needle_text(img), dim), quiet);
  const std::vector<double>& E = sim.youngs_modulus();
  EXPECT_EQ(E.size(), mesh.n_cells());

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::Matrix<double, dim, dim> A;
  for (int i = 0; i < dim; ++i)
    for (int j = 0; j < dim; ++j) A(i, j) = 0.01 * U(rng);
  std::vector<V> affine, random;
  for (const auto& p : mesh.points) {
    affine.push_back(A * p + V::Constant(0.3));
    V r;
    for (int d = 0; d < dim; ++d) r[d] = 0.01 * U(rng);
    random.push_back(r);
  }
  double truth_affine = 0.0, truth_random = 0.0, slack_affine = 0.0, slack_random = 0.0;
  EnergyErrors e;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    const test::SimplexIntegral I = test::integral_over_simplex<dim>(img, x);
    const double vol = std::abs(signed_volume<dim>(x));
    EXPECT_NEAR(I.covered, vol, 1e-11 * vol) << "clipping must partition element " << c;
    std::array<V, dim + 1> ur;
    for (int k = 0; k <= dim; ++k) ur[k] = random[mesh.cells[c][k]];
    const double da = test::strain_energy_density<dim>(A, kEq15Nu),
                 dr = test::strain_energy_density<dim>(test::p1_gradient<dim>(x, ur), kEq15Nu);
    truth_affine += da * kScale * I.integral;
    truth_random += dr * kScale * I.integral;
    slack_affine += da * kScale * (I.max - I.min) * vol;
    slack_random += dr * kScale * (I.max - I.min) * vol;
    const double exact_modulus = kScale * I.integral / vol;
    e.max_element_modulus = std::max(e.max_element_modulus, std::abs(E[c] - exact_modulus) / exact_modulus);
  }
  const auto& K = sim.model();
  e.affine = std::abs(K.strain_energy_of(affine) - truth_affine) / truth_affine;
  e.random = std::abs(K.strain_energy_of(random) - truth_random) / truth_random;
  e.bound_affine = slack_affine / truth_affine;
  e.bound_random = slack_random / truth_random;
  return e;
}

// Grid mesher (the CLI's --mesher grid): regular grid, element values by VoxelStatistics::value.
template <int dim>
std::vector<ElementValue> grid_values(const Image<dim>& img, const SimplexMesh<dim>& mesh) {
  const VoxelStatistics<dim> stats(img);
  std::vector<ElementValue> v;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) v.push_back(stats.value(cell_points(mesh, c)));
  return v;
}

template <int dim>
void expect_block_grid_exact(const Image<dim>& img, const std::array<long, dim>& blocks) {
  std::array<int, dim> nodes;
  for (int a = 0; a < dim; ++a) nodes[a] = static_cast<int>(blocks[a]) + 1;  // one grid cell per block
  const auto mesh = regular_grid_mesh<dim>(img.box_min(), img.box_max(), nodes);
  const EnergyErrors e = energy_errors<dim>(img, mesh, grid_values<dim>(img, mesh));
  std::printf("%dD block grid (%zu elements): element modulus %.1e, energy affine %.1e random %.1e\n", dim,
              mesh.n_cells(), e.max_element_modulus, e.affine, e.random);
  EXPECT_LT(e.max_element_modulus, 1e-10);
  EXPECT_LT(e.affine, 1e-10);
  EXPECT_LT(e.random, 1e-10);
}

// VIM from the CLI's initial grid for `budget` nodes, default options; the ceilings are the stated
// measured bounds on the energy errors of the affine and of the random P1 field.
template <int dim>
void expect_vim_within_bounds(const Image<dim>& img, long budget, double ceiling_affine,
                              double ceiling_random) {
  const auto nodes = nodes_per_axis_for_budget<dim>(img.box_min(), img.box_max(), budget);
  const auto r =
      optimize<dim>(img, regular_grid_mesh<dim>(img.box_min(), img.box_max(), nodes), VimOptions{});
  const EnergyErrors e = energy_errors<dim>(img, r.mesh, r.values);
  std::printf("%dD VIM (%zu elements): energy error affine %.3e random %.3e, derived bounds %.3e %.3e\n", dim,
              r.mesh.n_cells(), e.affine, e.random, e.bound_affine, e.bound_random);
  EXPECT_LE(e.affine, e.bound_affine);
  EXPECT_LE(e.random, e.bound_random);
  EXPECT_LT(e.affine, ceiling_affine);
  EXPECT_LT(e.random, ceiling_random);
}

}  // namespace

TEST(Eq15EndToEnd, BlockAlignedGridMesh3dIsExact) {
  const std::array<long, 3> blocks{{5, 4, 6}};
  expect_block_grid_exact<3>(checkerboard<3>(blocks, {{0.5, 0.6, 0.7}}, {{-3.0, 2.0, 1.0}}), blocks);
}

TEST(Eq15EndToEnd, BlockAlignedGridMesh2dIsExact) {
  const std::array<long, 2> blocks{{9, 7}};
  expect_block_grid_exact<2>(checkerboard<2>(blocks, {{0.5, 0.8}}, {{1.0, -2.0}}), blocks);
}

// Measured (this build, deterministic for any thread count): 3D, 512 nodes, 1386 elements: energy error
// 2.6e-3 (affine) and 3.1e-4 (random P1 field); 2D, 200 nodes, 308 elements: 2.4e-3 and 2.7e-2. The
// ceilings are about twice to three times these. The centroid value in place of the voxel-centre mean
// (tests/sabotage/centroid-instead-of-mean.patch) gives 4.9e-3 and 6.2e-3 in 3D, above the random
// field's ceiling; in 2D (about 3 voxels per triangle) it gives about the same errors as the mean, so
// only the 3D case detects it.
TEST(Eq15EndToEnd, VimMesh3dWithinTheVoxelCentreBound) {
  expect_vim_within_bounds<3>(checkerboard<3>({{5, 4, 6}}, {{0.5, 0.6, 0.7}}, {{-3.0, 2.0, 1.0}}), 512, 5e-3,
                              1e-3);
}

TEST(Eq15EndToEnd, VimMesh2dWithinTheVoxelCentreBound) {
  expect_vim_within_bounds<2>(checkerboard<2>({{9, 7}}, {{0.5, 0.8}}, {{1.0, -2.0}}), 200, 5e-3, 5e-2);
}

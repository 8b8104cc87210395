// Tests of the connectivity updates of paper §IV-B (GRUMMP-style swaps): a 2D edge flip and the 3D
// 2-3, 3-2 and 4-4 swaps on hand-made configurations over random step images. Each swap must keep
// the covered volume and a valid adjacency, and be taken exactly when the alternative connectivity
// has a lower E (Eq. 7) by a brute-force per-voxel computation independent of the optimiser.
#include "optimizer_test_util.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/optimizer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>
#include <set>

namespace vim {
namespace {

using testing::brute_force_energy;

// Image over [-1.2, 1.2]^dim (odd origin/spacing so voxel centres avoid the mesh's planes) with
// value 2 on one side of a random plane near the origin, 1 on the other.
template <int dim>
Image<dim> step_image(std::mt19937& rng, long n) {
  std::array<long, dim> size;
  std::array<double, dim> spacing, origin;
  size.fill(n);
  spacing.fill(2.4 / static_cast<double>(n) * 1.0000137);
  origin.fill(-1.2 + 0.5 * spacing[0] + 0.0003141);
  Image<dim> img(size, spacing, origin, 1.0f);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  Eigen::Matrix<double, dim, 1> normal;
  for (int a = 0; a < dim; ++a) normal[a] = g(rng);
  normal.normalize();
  const double offset = u(rng);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if (normal.dot(img.point_of(img.index_of(k))) > offset) img.data[k] = 2.0f;
  return img;
}

template <int dim>
double live_volume(const VimOptimizer<dim>& opt) {
  return total_volume(opt.compact_mesh());
}

template <int dim>
std::set<std::array<int, dim + 1>> cell_set(const SimplexMesh<dim>& m) {
  std::set<std::array<int, dim + 1>> s;
  for (auto c : m.cells) {
    std::sort(c.begin(), c.end());
    s.insert(c);
  }
  return s;
}

// Runs `trials` random images; `swap` applies the swap under test to a fresh optimiser, and
// `alternatives` lists the meshes the swap may produce. Checks the decision against brute force.
template <int dim>
void check_swap(const SimplexMesh<dim>& initial, const std::vector<SimplexMesh<dim>>& alternatives,
                const std::function<bool(VimOptimizer<dim>&)>& swap, int trials, bool expect_both_outcomes) {
  std::mt19937 rng(2024 + dim);
  int taken = 0, rejected = 0;
  for (int t = 0; t < trials; ++t) {
    const Image<dim> img = step_image<dim>(rng, dim == 2 ? 120 : 40);
    VimOptions o;
    o.lambda = (t % 2) ? 0.95 : 0.5;
    VimOptimizer<dim> opt(initial, nullptr, nullptr, o);  // geometry-only instance for the volume
    const VoxelStatistics<dim> stats(img);
    VimOptimizer<dim> vim(initial, &stats, nullptr, o);
    const auto old_brute = brute_force_energy(img, initial);
    const double eg0 = old_brute.eg, ed0 = old_brute.ed;
    const double e_old = old_brute.combined(eg0, ed0, o.lambda);
    double e_best = e_old;
    int best = -1;
    for (std::size_t a = 0; a < alternatives.size(); ++a) {
      const double e = brute_force_energy(img, alternatives[a]).combined(eg0, ed0, o.lambda);
      if (e < e_best) {
        e_best = e;
        best = static_cast<int>(a);
      }
    }
    // Skip near-ties, where the voxel tie rule may decide differently from the brute force.
    bool near_tie = false;
    for (const auto& alt : alternatives)
      near_tie = near_tie || std::abs(brute_force_energy(img, alt).combined(eg0, ed0, o.lambda) - e_old) < 1e-6;
    const double volume = live_volume(vim);
    const bool did = swap(vim);
    EXPECT_NEAR(live_volume(vim), volume, 1e-12 * volume);
    EXPECT_TRUE(vim.adjacency().consistent(vim.mesh().n_points(), vim.mesh().cells, vim.alive()));
    const auto after = vim.compact_mesh();
    const double e_after = vim.totals().energy;
    EXPECT_NEAR(e_after, brute_force_energy(img, after).combined(eg0, ed0, o.lambda), 1e-9);
    if (near_tie) continue;
    EXPECT_EQ(did, best >= 0) << "trial " << t << " E_old " << e_old << " E_best " << e_best;
    if (did) {
      ++taken;
      EXPECT_LT(e_after, e_old);
      if (best >= 0) {
        EXPECT_EQ(cell_set<dim>(after), cell_set<dim>(alternatives[best]));
      }
    } else {
      ++rejected;
      EXPECT_EQ(cell_set<dim>(after), cell_set<dim>(initial));
    }
  }
  if (expect_both_outcomes) {
    EXPECT_GT(taken, 0);
    EXPECT_GT(rejected, 0);
  } else {
    EXPECT_EQ(taken, 0);
  }
}

SimplexMesh<2> quad(const std::array<int, 3>& t0, const std::array<int, 3>& t1) {
  SimplexMesh<2> m;
  m.points = {{-0.9, -1.0}, {1.0, -0.95}, {1.05, 1.0}, {-1.0, 0.9}};
  m.cells = {t0, t1};
  orient_positively(m);
  return m;
}

TEST(Swaps, EdgeFlip2D) {
  const auto initial = quad({0, 1, 2}, {0, 2, 3});
  const auto flipped = quad({1, 2, 3}, {1, 3, 0});
  check_swap<2>(initial, {flipped}, [](VimOptimizer<2>& o) {
    const auto& c = o.mesh().cells[0];
    const int k = static_cast<int>(std::find(c.begin(), c.end(), 1) - c.begin());  // edge 0-2 is opposite node 1
    return o.try_flip(0, k);
  }, 16, true);
}

TEST(Swaps, EdgeFlipOfNonConvexQuadIsNeverTaken) {
  SimplexMesh<2> m;
  m.points = {{-1.0, -1.0}, {1.0, -1.0}, {-0.2, -0.1}, {-1.0, 1.0}};  // node 2 makes the quad non-convex at 2
  m.cells = {{0, 1, 2}, {0, 2, 3}};
  orient_positively(m);
  SimplexMesh<2> flipped = m;
  flipped.cells = {{1, 2, 3}, {1, 3, 0}};
  orient_positively(flipped);
  check_swap<2>(m, {flipped}, [](VimOptimizer<2>& o) {
    const auto& c = o.mesh().cells[0];
    return o.try_flip(0, static_cast<int>(std::find(c.begin(), c.end(), 1) - c.begin()));
  }, 6, false);
}

// Triangle a b c (indices 0,1,2) in z ≈ 0 with apexes d = 3 above and e = 4 below.
SimplexMesh<3> bipyramid(const Eigen::Vector3d& e_point, bool three) {
  SimplexMesh<3> m;
  m.points = {{1.0, 0.0, 0.02}, {-0.5, 0.866, -0.01}, {-0.5, -0.866, 0.0}, {0.05, 0.03, 0.8}, e_point};
  if (three)
    m.cells = {{3, 4, 0, 1}, {3, 4, 1, 2}, {3, 4, 2, 0}};
  else
    m.cells = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  orient_positively(m);
  return m;
}

TEST(Swaps, TwoToThree3D) {
  const Eigen::Vector3d e(-0.04, 0.02, -0.75);
  check_swap<3>(bipyramid(e, false), {bipyramid(e, true)}, [](VimOptimizer<3>& o) {
    const auto& c = o.mesh().cells[0];
    return o.try_swap_23(0, static_cast<int>(std::find(c.begin(), c.end(), 3) - c.begin()));
  }, 16, true);
}

TEST(Swaps, TwoToThreeNeedsTheNewEdgeThroughTheFacet) {
  const Eigen::Vector3d e(2.0, 0.0, -0.5);  // segment d-e misses triangle a b c
  check_swap<3>(bipyramid(e, false), {bipyramid(e, true)}, [](VimOptimizer<3>& o) {
    const auto& c = o.mesh().cells[0];
    return o.try_swap_23(0, static_cast<int>(std::find(c.begin(), c.end(), 3) - c.begin()));
  }, 6, false);
}

TEST(Swaps, ThreeToTwo3D) {
  const Eigen::Vector3d e(-0.04, 0.02, -0.75);
  check_swap<3>(bipyramid(e, true), {bipyramid(e, false)}, [](VimOptimizer<3>& o) { return o.try_swap_32(3, 4); },
                16, true);
}

// Octahedron: edge a = 0, b = 1 with the ring p0..p3 = 2..5.
SimplexMesh<3> octahedron(int diagonal) {
  SimplexMesh<3> m;
  m.points = {{0.0, 0.01, 1.0}, {0.03, -0.02, -1.0}, {1.0, 0.0, 0.0}, {0.02, 1.0, 0.01}, {-1.0, 0.01, -0.02}, {0.0, -1.0, 0.0}};
  if (diagonal == 0)
    m.cells = {{0, 1, 2, 3}, {0, 1, 3, 4}, {0, 1, 4, 5}, {0, 1, 5, 2}};
  else if (diagonal == 1)  // p0-p2 = nodes 2-4
    m.cells = {{2, 4, 3, 0}, {2, 4, 3, 1}, {2, 4, 5, 0}, {2, 4, 5, 1}};
  else  // p1-p3 = nodes 3-5
    m.cells = {{3, 5, 2, 0}, {3, 5, 2, 1}, {3, 5, 4, 0}, {3, 5, 4, 1}};
  orient_positively(m);
  return m;
}

TEST(Swaps, FourToFour3D) {
  check_swap<3>(octahedron(0), {octahedron(1), octahedron(2)}, [](VimOptimizer<3>& o) { return o.try_swap_44(0, 1); },
                16, true);
}

TEST(Swaps, SwapPassLowersEnergyAndKeepsMeshValid) {
  std::mt19937 rng(5);
  const auto img = step_image<3>(rng, 30);
  auto mesh = regular_grid_mesh<3>(img.box_min(), img.box_max(), std::array<int, 3>{4, 4, 4});
  const VoxelStatistics<3> stats(img);
  VimOptions o;
  o.lambda = 0.9;
  VimOptimizer<3> vim(mesh, &stats, nullptr, o);
  const double before = vim.totals().energy, volume = live_volume(vim);
  const long swaps = vim.swap_pass();
  EXPECT_GT(swaps, 0);
  EXPECT_LT(vim.totals().energy, before);
  EXPECT_NEAR(live_volume(vim), volume, 1e-9 * volume);
  EXPECT_TRUE(vim.adjacency().consistent(vim.mesh().n_points(), vim.mesh().cells, vim.alive()));
  const auto q = mesh_quality<3>(vim.compact_mesh());
  EXPECT_EQ(q.inverted, 0);
  EXPECT_LE(q.max_dihedral_deg, 150.0 + 1e-9);
  // Caches equal a fresh evaluation of every element.
  const auto fresh = vim.recompute_totals();
  EXPECT_NEAR(vim.totals().energy, fresh.energy, 1e-12 * fresh.energy);
}

}  // namespace
}  // namespace vim

// Tests of VoxelStatistics (voxel enclosure by rows + prefix sums, paper Eq. 4–6):
// partition of the voxel centres on tie-heavy grid-aligned and perturbed meshes, and agreement with
// an independent per-voxel barycentric enumeration on random simplices, images and spacings.
#include "primitives_test_util.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/voxel_statistics.hpp>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include <random>
#include <thread>

namespace vim {
namespace {

using testing::perturbed_grid_mesh;
using testing::random_image;

// Every voxel centre is contained in exactly one cell (checked voxel by voxel), the row/prefix-sum
// counts equal the per-voxel counts per cell, and the totals match the image.
template <int dim>
void expect_partition(const Image<dim>& img, const SimplexMesh<dim>& mesh) {
  const VoxelStatistics<dim> stats(img);
  std::vector<int> owners(img.voxel_count(), 0);
  long total_n = 0;
  double total_s = 0.0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    const auto s = stats.sums(x);
    const auto r = stats.sums_per_voxel(x);
    ASSERT_EQ(s.n, r.n) << "cell " << c;
    EXPECT_NEAR(s.s, r.s, 1e-9 * (1.0 + std::abs(r.s)));
    EXPECT_NEAR(s.q, r.q, 1e-9 * (1.0 + r.q));
    total_n += s.n;
    total_s += s.s;
    for (std::size_t k = 0; k < img.voxel_count(); ++k)
      if (stats.contains(x, img.index_of(k))) ++owners[k];
  }
  EXPECT_EQ(total_n, static_cast<long>(img.voxel_count()));
  double expected_s = 0.0;
  for (float v : img.data) expected_s += v - stats.shift();
  EXPECT_NEAR(total_s, expected_s, 1e-8);
  long wrong = 0;
  for (int o : owners) wrong += o != 1;
  EXPECT_EQ(wrong, 0) << "voxel centres not owned by exactly one cell";
}

TEST(VoxelStatistics, PartitionNodesOnVoxelCentres2D) {
  std::mt19937 rng(1);
  const auto img = random_image<2>({13, 10}, {0.7, 1.3}, {-2.0, 5.0}, rng);
  // Nodes every 2 voxels on axis 0, every 3 on axis 1, starting at the first voxel centre.
  const auto mesh = regular_grid_mesh<2>(img.point_of({0, 0}), img.point_of({12, 9}), {7, 4});
  expect_partition(img, mesh);
}

TEST(VoxelStatistics, PartitionNodesOnVoxelCentres3D) {
  std::mt19937 rng(2);
  const auto img = random_image<3>({9, 7, 5}, {0.5, 0.5, 3.0}, {1.0, -4.0, 2.5}, rng);
  const auto mesh = regular_grid_mesh<3>(img.point_of({0, 0, 0}), img.point_of({8, 6, 4}), {5, 4, 3});
  expect_partition(img, mesh);
}

TEST(VoxelStatistics, PartitionNodesOnVoxelFacesAndCentres2D) {
  std::mt19937 rng(3);
  const auto img = random_image<2>({12, 9}, {0.3, 0.9}, {0.25, -1.0}, rng);
  // Image box; cells of 1.5 voxels (nodes alternate between voxel faces and centres) and 3 voxels.
  expect_partition(img, regular_grid_mesh<2>(img.box_min(), img.box_max(), {9, 4}));
  expect_partition(img, regular_grid_mesh<2>(img.box_min(), img.box_max(), {5, 10}));
}

TEST(VoxelStatistics, PartitionNodesOnVoxelFacesAndCentres3D) {
  std::mt19937 rng(4);
  const auto img = random_image<3>({6, 9, 4}, {0.4, 0.4, 1.7}, {-3.0, 0.1, 7.0}, rng);
  expect_partition(img, regular_grid_mesh<3>(img.box_min(), img.box_max(), {5, 7, 3}));  // 1.5, 1.5, 2 voxels
  expect_partition(img, regular_grid_mesh<3>(img.box_min(), img.box_max(), {7, 10, 5}));  // 1 voxel per cell
}

TEST(VoxelStatistics, PartitionPerturbedMeshes) {
  std::mt19937 rng(5);
  const auto img2 = random_image<2>({20, 15}, {0.6, 0.8}, {3.0, -2.0}, rng);
  for (int rep = 0; rep < 3; ++rep)
    expect_partition(img2, perturbed_grid_mesh<2>(img2.box_min(), img2.box_max(), {6, 5}, 0.3, rng));
  const auto img3 = random_image<3>({10, 8, 7}, {0.6, 0.8, 1.5}, {3.0, -2.0, 0.5}, rng);
  for (int rep = 0; rep < 2; ++rep)
    expect_partition(img3, perturbed_grid_mesh<3>(img3.box_min(), img3.box_max(), {4, 4, 3}, 0.3, rng));
}

// Independent truth: barycentric coordinates of every voxel centre by an LU solve in physical
// space; random simplices have no centre on a face, so strict inclusion is unambiguous.
template <int dim>
void expect_matches_bruteforce(const std::array<long, dim>& size, const std::array<double, dim>& spacing,
                               const std::array<double, dim>& origin, int trials, unsigned seed) {
  std::mt19937 rng(seed);
  const auto img = random_image<dim>(size, spacing, origin, rng);
  const VoxelStatistics<dim> stats(img);
  const auto lo = img.box_min(), hi = img.box_max();
  std::uniform_real_distribution<double> u(-0.1, 1.1);  // some vertices outside the image box
  long nonempty = 0;
  for (int t = 0; t < trials; ++t) {
    typename VoxelStatistics<dim>::Simplex x;
    for (auto& p : x)
      for (int a = 0; a < dim; ++a) p[a] = lo[a] + u(rng) * (hi[a] - lo[a]);
    if (t % 3 == 0)  // small elements too (≈ 10 voxels across)
      for (int k = 1; k <= dim; ++k) x[k] = x[0] + 0.2 * (x[k] - x[0]);
    Eigen::Matrix<double, dim, dim> m;
    for (int k = 0; k < dim; ++k) m.col(k) = x[k + 1] - x[0];
    const auto lu = m.fullPivLu();
    std::vector<double> inside;
    for (std::size_t k = 0; k < img.voxel_count(); ++k) {
      const Eigen::Matrix<double, dim, 1> l = lu.solve(img.point_of(img.index_of(k)) - x[0]);
      if (l.minCoeff() > 0.0 && l.sum() < 1.0) inside.push_back(img.data[k]);
    }
    const auto v = stats.value(x);
    ASSERT_EQ(v.voxels, static_cast<long>(inside.size())) << "trial " << t;
    if (inside.empty()) {
      EXPECT_DOUBLE_EQ(v.mean, img.interpolate(centroid<dim>(x)));
      EXPECT_EQ(v.variance, 0.0);
      continue;
    }
    ++nonempty;
    double mean = 0.0;
    for (double h : inside) mean += h;
    mean /= static_cast<double>(inside.size());
    double var = 0.0;
    for (double h : inside) var += (h - mean) * (h - mean);
    var /= static_cast<double>(inside.size());
    EXPECT_NEAR(v.mean, mean, 1e-10);
    EXPECT_NEAR(v.variance, var, 1e-10);
    const auto s = stats.sums(x);
    EXPECT_NEAR(s.s, static_cast<double>(inside.size()) * (mean - stats.shift()), 1e-8);
  }
  EXPECT_GT(nonempty, trials / 2);
}

TEST(VoxelStatistics, MatchesBruteForce2D) {
  expect_matches_bruteforce<2>({37, 23}, {0.5, 1.7}, {-10.0, 4.0}, 300, 11);
}

TEST(VoxelStatistics, MatchesBruteForce3D) {
  expect_matches_bruteforce<3>({17, 13, 11}, {0.5, 0.5, 3.0}, {2.0, -7.0, 1.0}, 150, 12);
}

// Row clipping (fast crossing + exact tie path) against the per-voxel scan with the same predicate,
// on simplices whose vertices snap to quarter-voxel positions: many centres lie exactly on faces.
template <int dim>
void expect_rows_match_per_voxel_on_ties(unsigned seed) {
  std::mt19937 rng(seed);
  std::array<long, dim> size;
  std::array<double, dim> sp, org;
  for (int a = 0; a < dim; ++a) {
    size[a] = 9 + 2 * a;
    sp[a] = 0.4 + 0.3 * a;
    org[a] = 1.0 - a;
  }
  const auto img = random_image<dim>(size, sp, org, rng);
  const VoxelStatistics<dim> stats(img);
  std::uniform_int_distribution<int> q(-6, 4 * static_cast<int>(size[0]) + 6);
  long ties = 0;
  for (int t = 0; t < 400; ++t) {
    typename VoxelStatistics<dim>::Simplex x;
    for (auto& p : x)
      for (int a = 0; a < dim; ++a) p[a] = org[a] + sp[a] * 0.25 * q(rng);
    if (std::abs(signed_volume<dim>(x)) < 1e-9) continue;
    const auto s = stats.sums(x), r = stats.sums_per_voxel(x);
    ASSERT_EQ(s.n, r.n) << "trial " << t;
    EXPECT_NEAR(s.s, r.s, 1e-9 * (1.0 + std::abs(r.s)));
    for (std::size_t k = 0; k < img.voxel_count(); ++k) {  // count centres on a face (ties)
      const auto c = img.continuous_index(img.point_of(img.index_of(k)));
      Eigen::Matrix<double, dim, dim> m;
      for (int d = 0; d < dim; ++d) m.col(d) = img.continuous_index(x[d + 1]) - img.continuous_index(x[0]);
      const Eigen::Matrix<double, dim, 1> l = m.fullPivLu().solve(c - img.continuous_index(x[0]));
      const double l0 = 1.0 - l.sum();
      const bool inside = l.minCoeff() >= -1e-12 && l0 >= -1e-12;
      ties += inside && (std::abs(l.minCoeff()) < 1e-12 || std::abs(l0) < 1e-12);
    }
  }
  EXPECT_GT(ties, 20);  // the case is really tie-heavy
}

TEST(VoxelStatistics, RowsMatchPerVoxelScanOnTies2D) { expect_rows_match_per_voxel_on_ties<2>(21); }
TEST(VoxelStatistics, RowsMatchPerVoxelScanOnTies3D) { expect_rows_match_per_voxel_on_ties<3>(22); }

// uniform(x) is exactly "no voxel of x's index bounding box differs from an axis neighbour"
// (brute force over the box, own bounding-box computation), and then every voxel centre in x holds
// one value; varied_sums is sums() exactly when x is not uniform. Blocky images (constant blocks of
// random size and value) give both answers often.
template <int dim>
void expect_uniform_is_exact(long n, int trials, unsigned seed) {
  std::mt19937 rng(seed);
  std::array<long, dim> size;
  std::array<double, dim> spacing, origin;
  for (int a = 0; a < dim; ++a) {
    size[a] = n + a;
    spacing[a] = 0.7 + 0.3 * a;
    origin[a] = -1.0 + a;
  }
  Image<dim> img(size, spacing, origin, 1.0f);
  std::uniform_int_distribution<long> pos(0, n - 1), len(2, n / 2);
  std::uniform_int_distribution<int> level(1, 3);
  for (int b = 0; b < 6; ++b) {  // constant boxes painted over a constant background
    std::array<long, dim> lo, hi;
    for (int a = 0; a < dim; ++a) {
      lo[a] = pos(rng);
      hi[a] = std::min(size[a] - 1, lo[a] + len(rng));
    }
    const float v = static_cast<float>(level(rng));
    for (std::size_t k = 0; k < img.voxel_count(); ++k) {
      const auto i = img.index_of(k);
      bool in = true;
      for (int a = 0; a < dim; ++a) in = in && i[a] >= lo[a] && i[a] <= hi[a];
      if (in) img.data[k] = v;
    }
  }
  const VoxelStatistics<dim> stats(img);
  const auto blo = img.box_min(), bhi = img.box_max();
  std::uniform_real_distribution<double> u(-0.05, 1.05), shrink(0.03, 0.4);
  int uniform_seen = 0, varied_seen = 0;
  for (int t = 0; t < trials; ++t) {
    typename VoxelStatistics<dim>::Simplex x;
    for (auto& p : x)
      for (int a = 0; a < dim; ++a) p[a] = blo[a] + u(rng) * (bhi[a] - blo[a]);
    const double f = shrink(rng);
    for (int k = 1; k <= dim; ++k) x[k] = x[0] + f * (x[k] - x[0]);
    // Index box: voxel centres within 1e-6 (relative) of the vertices' continuous-index range.
    std::array<long, dim> lo, hi;
    bool empty = false;
    for (int a = 0; a < dim; ++a) {
      double mn = 1e300, mx = -1e300, big = 0.0;
      for (const auto& p : x)
        for (int b = 0; b < dim; ++b) big = std::max(big, std::abs(img.continuous_index(p)[b]));
      for (const auto& p : x) {
        mn = std::min(mn, img.continuous_index(p)[a]);
        mx = std::max(mx, img.continuous_index(p)[a]);
      }
      lo[a] = std::max(0L, static_cast<long>(std::ceil(mn - 1e-6 * (1.0 + big))));
      hi[a] = std::min(size[a] - 1, static_cast<long>(std::floor(mx + 1e-6 * (1.0 + big))));
      empty = empty || lo[a] > hi[a];
    }
    bool edge = false;
    for (std::size_t k = 0; k < img.voxel_count() && !empty && !edge; ++k) {
      auto i = img.index_of(k);
      bool in = true;
      for (int a = 0; a < dim; ++a) in = in && i[a] >= lo[a] && i[a] <= hi[a];
      if (!in) continue;
      for (int a = 0; a < dim && !edge; ++a)
        for (int d : {-1, 1}) {
          auto j = i;
          j[a] += d;
          if (j[a] >= 0 && j[a] < size[a] && img.at(j) != img.at(i)) edge = true;
        }
    }
    const bool uniform = stats.uniform(x);
    ASSERT_EQ(uniform, !edge) << "trial " << t;
    typename VoxelStatistics<dim>::Sums vs;
    ASSERT_EQ(stats.varied_sums(x, vs), !uniform) << "trial " << t;
    const auto ref = stats.sums_per_voxel(x);
    if (uniform) {
      ++uniform_seen;
      if (ref.n > 0) {  // the one-voxel stand-in holds the value of every centre in x
        EXPECT_EQ(vs.n, 1);
        EXPECT_NEAR(vs.s, ref.s / static_cast<double>(ref.n), 1e-12);
        EXPECT_NEAR(vs.q, vs.s * vs.s, 1e-12);
      }
      EXPECT_NEAR(stats.value(x).variance, 0.0, 1e-12) << "trial " << t;  // round-off of the sums only
      if (ref.n > 0) {
        EXPECT_NEAR(ref.q * static_cast<double>(ref.n), ref.s * ref.s, 1e-9 * (1.0 + ref.s * ref.s));
      }
    } else {
      ++varied_seen;
      const auto s = stats.sums(x);
      EXPECT_EQ(vs.n, s.n);
      EXPECT_EQ(vs.s, s.s);
      EXPECT_EQ(vs.q, s.q);
    }
  }
  EXPECT_GT(uniform_seen, trials / 10);
  EXPECT_GT(varied_seen, trials / 10);
}

TEST(VoxelStatistics, UniformIsExactlyNoEdgeVoxelInTheBox2D) { expect_uniform_is_exact<2>(40, 400, 31); }
TEST(VoxelStatistics, UniformIsExactlyNoEdgeVoxelInTheBox3D) { expect_uniform_is_exact<3>(18, 300, 32); }

TEST(VoxelStatistics, EmptyElementTakesCentroidValue) {
  // Linear image h = 1 + 2i + 3j: the centroid sample is exact.
  Image<2> img({5, 5}, {1.0, 2.0}, {0.0, 0.0});
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto i = img.index_of(k);
    img.data[k] = static_cast<float>(1 + 2 * i[0] + 3 * i[1]);
  }
  const VoxelStatistics<2> stats(img);
  const VoxelStatistics<2>::Simplex x{Eigen::Vector2d(1.1, 2.2), Eigen::Vector2d(1.9, 2.2), Eigen::Vector2d(1.1, 3.8)};
  const auto v = stats.value(x);
  EXPECT_EQ(v.voxels, 0);
  const Eigen::Vector2d c = centroid<2>(x);
  EXPECT_NEAR(v.mean, 1 + 2 * c[0] + 3 * c[1] / 2.0, 1e-12);
  EXPECT_EQ(v.variance, 0.0);
}

TEST(VoxelStatistics, ConstantImageHasZeroVariance) {
  Image<3> img({6, 5, 4}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}, 4.5f);
  const VoxelStatistics<3> stats(img);
  EXPECT_DOUBLE_EQ(stats.shift(), 4.5);
  const VoxelStatistics<3>::Simplex x{Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(5.5, -0.5, -0.5),
                                      Eigen::Vector3d(-0.5, 4.5, -0.5), Eigen::Vector3d(-0.5, -0.5, 3.5)};
  const auto v = stats.value(x);
  EXPECT_GT(v.voxels, 0);
  EXPECT_DOUBLE_EQ(v.mean, 4.5);
  EXPECT_EQ(v.variance, 0.0);
}

TEST(VoxelStatistics, ConcurrentCallsAgree) {
  std::mt19937 rng(13);
  const auto img = random_image<3>({12, 12, 12}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}, rng);
  const VoxelStatistics<3> stats(img);
  const auto mesh = perturbed_grid_mesh<3>(img.box_min(), img.box_max(), {5, 5, 5}, 0.3, rng);
  std::vector<double> serial(mesh.n_cells()), a(mesh.n_cells()), b(mesh.n_cells());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) serial[c] = stats.value(cell_points(mesh, c)).mean;
  auto run = [&](std::vector<double>& out) {
    for (std::size_t c = 0; c < mesh.n_cells(); ++c) out[c] = stats.value(cell_points(mesh, c)).mean;
  };
  std::thread t1(run, std::ref(a)), t2(run, std::ref(b));
  t1.join();
  t2.join();
  EXPECT_EQ(a, serial);
  EXPECT_EQ(b, serial);
}

TEST(VoxelStatistics, RejectsInconsistentImage) {
  Image<2> img({4, 4}, {1.0, 1.0}, {0.0, 0.0});
  img.data.pop_back();
  EXPECT_THROW(VoxelStatistics<2> s(img), std::invalid_argument);
  Image<2> bad({4, 4}, {1.0, 0.0}, {0.0, 0.0});
  EXPECT_THROW(VoxelStatistics<2> s(bad), std::invalid_argument);
}

// Elements whose voxels all hold one value get exactly that value as their mean (the exports bin
// materials by it: 0.9999999999999999 and 1.0 were two materials), while the sums stay about the
// image mean. Background 0.3 (not a binary fraction) with a brighter block; every element whose voxel
// centres are all background, found by brute force, must have mean == 0.3f exactly and variance 0.
TEST(VoxelStatistics, UniformElementsGetTheirValueExactly) {
  Image<3> img({20, 20, 20}, {1, 1, 1}, {0, 0, 0}, 0.3f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto i = img.index_of(k);
    if (i[0] >= 12 && i[1] >= 5 && i[2] < 9) img.data[k] = 7.77f;
  }
  VoxelStatistics<3> st(img);
  const auto mesh = regular_grid_mesh<3>(Eigen::Vector3d::Constant(-0.5), Eigen::Vector3d::Constant(19.5), {{6, 6, 6}});
  int uniform = 0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    const auto v = st.value(x);
    const auto s = st.sums_per_voxel(x);  // brute force: every voxel of the box with the same predicate
    bool all_background = s.n > 0;
    for (std::size_t k = 0; k < img.voxel_count() && all_background; ++k)
      if (img.data[k] != 0.3f && st.contains(x, img.index_of(k))) all_background = false;
    if (!all_background) continue;
    ++uniform;
    EXPECT_EQ(v.mean, static_cast<double>(0.3f)) << "cell " << c;
    EXPECT_EQ(v.variance, 0.0) << "cell " << c;
    EXPECT_EQ(v.voxels, s.n) << "cell " << c;
  }
  EXPECT_GT(uniform, 100);
}

}  // namespace
}  // namespace vim

// VIM on label images (docs/labels.md): the label data term Σ_l var(1_l), the majority rule and the
// misclassified volume. Truth: the independent voxel-centre classification of
// tests/support/label_truth.hpp (barycentric tests, per-element label counts, Σ_l p_l(1−p_l)).
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <vim/initial_mesh.hpp>
#include <vim/label_statistics.hpp>
#include <vim/optimizer.hpp>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

#include "label_truth.hpp"

namespace vim {
namespace {

Image<3> cube_labels(long n, double spacing, float fill) {
  std::array<long, 3> size{n, n, n};
  std::array<double, 3> sp{spacing, spacing, spacing};
  std::array<double, 3> origin{0.5 * spacing, 0.5 * spacing, 0.5 * spacing};
  return Image<3>(size, sp, origin, fill);
}

// Three labels (1, 2, 7) in slabs and a ball: the label values are not equally spaced, so the variance
// of the values differs from the summed indicator variances.
Image<3> three_labels(long n) {
  Image<3> img = cube_labels(n, 1.0, 1.0f);
  const Eigen::Vector3d c(0.45 * n, 0.55 * n, 0.5 * n);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto p = img.point_of(img.index_of(k));
    if (p[0] > 0.6 * n) img.data[k] = 2.0f;
    if ((p - c).norm() < 0.3 * n) img.data[k] = 7.0f;
  }
  return img;
}

SimplexMesh<3> grid_of(const Image<3>& img, long nodes) {
  const auto n = nodes_per_axis_for_budget<3>(img.box_min(), img.box_max(), nodes);
  return regular_grid_mesh<3>(img.box_min(), img.box_max(), n);
}

TEST(LabelStatistics, IndicatorVarianceAndMajorityMatchBruteForce) {
  const Image<3> img = three_labels(16);
  const LabelStatistics<3> stats(img);
  ASSERT_EQ(stats.labels(), (std::vector<int>{1, 2, 7}));
  // A grid moved at random (no node crosses a neighbour), so faces cut the voxels generically.
  SimplexMesh<3> mesh = grid_of(img, 343);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  const auto lo = img.box_min(), hi = img.box_max();
  for (auto& p : mesh.points)
    for (int a = 0; a < 3; ++a)
      if (p[a] > lo[a] + 1e-9 && p[a] < hi[a] - 1e-9) p[a] += u(rng);
  const auto owner = test::label_owner(img, mesh);
  const auto counts = test::label_counts(img, owner, mesh.n_cells());
  const auto truth = test::majority_labels(img, mesh, counts);
  int mixed = 0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    EXPECT_NEAR(stats.indicator_variance(x), test::gini(counts[c]), 1e-12) << "cell " << c;
    EXPECT_EQ(stats.majority(x), truth[c]) << "cell " << c;
    mixed += counts[c].size() > 1;
  }
  EXPECT_GT(mixed, 20);  // the check covers elements across the labels' interfaces
}

TEST(LabelStatistics, NonIntegerLabelIsAnErrorNamingTheVoxel) {
  Image<3> img = cube_labels(4, 1.0, 1.0f);
  img.at({1, 2, 3}) = 2.5f;
  try {
    const LabelStatistics<3> stats(img);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("voxel (1,2,3) holds 2.5"), std::string::npos) << e.what();
  }
}

TEST(LabelVim, DataTermIsTheSummedIndicatorVarianceTimesVolume) {
  const Image<3> img = three_labels(16);
  const LabelStatistics<3> stats(img);
  VimOptions o;
  const VimOptimizer<3> opt(grid_of(img, 216), &stats.values(), nullptr, o, &stats);
  const SimplexMesh<3>& mesh = opt.mesh();
  const auto owner = test::label_owner(img, mesh);
  const auto counts = test::label_counts(img, owner, mesh.n_cells());
  double ed = 0.0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    ed += std::abs(signed_volume<3>(cell_points(mesh, c))) * test::gini(counts[c]);
  ASSERT_GT(ed, 0.0);
  EXPECT_NEAR(opt.totals().discretization, ed, 1e-9 * ed);
  EXPECT_NEAR(opt.ed0(), ed, 1e-9 * ed);  // §IV-C: E_D0 is the initial mesh's E_D
}

// Misclassified volume and the majority rule of a label mesh, by the independent classification.
struct LabelFit {
  double misclassified = 0.0;
  long wrong_majority = 0;
};

LabelFit fit_of(const Image<3>& img, const VimResult<3>& r) {
  const auto owner = test::label_owner(img, r.mesh);
  const auto counts = test::label_counts(img, owner, r.mesh.n_cells());
  const auto truth = test::majority_labels(img, r.mesh, counts);
  LabelFit f;
  for (std::size_t c = 0; c < r.mesh.n_cells(); ++c) f.wrong_majority += r.labels[c] != truth[c];
  f.misclassified = test::total(test::misclassified_volume(img, owner, r.labels));
  for (long o : owner) EXPECT_GE(o, 0) << "a voxel centre outside the mesh";
  return f;
}

TEST(LabelVim, PlaneThroughVoxelFacesIsFollowedExactly) {
  // Labels 3 (x index ≤ 9) and 5: the interface is the plane of voxel faces x = 10 (spacing 1),
  // which the 10×10×10 grid (node planes at x ≈ 8.9, 11.1) does not contain.
  Image<3> img = cube_labels(20, 1.0, 3.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if (img.index_of(k)[0] >= 10) img.data[k] = 5.0f;
  const SimplexMesh<3> grid = grid_of(img, 1000);
  ASSERT_EQ(grid.n_points(), 1000u);
  VimResult<3> before;
  before.mesh = grid;
  const LabelStatistics<3> stats(img);
  for (std::size_t c = 0; c < grid.n_cells(); ++c)
    before.labels.push_back(stats.majority(cell_points(grid, c)));
  const LabelFit f0 = fit_of(img, before);
  const VimResult<3> r = optimize_labels<3>(img, grid, VimOptions{});
  const LabelFit f = fit_of(img, r);
  const MeshQuality q = mesh_quality<3>(r.mesh);
  std::printf("plane: misclassified volume grid %.1f, VIM %.1f; max dihedral %.1f\n", f0.misclassified,
              f.misclassified, q.max_dihedral_deg);
  EXPECT_GT(f0.misclassified, 0.0);
  EXPECT_EQ(f.misclassified, 0.0);
  EXPECT_EQ(f.wrong_majority, 0);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_LE(q.max_dihedral_deg, 150.0 + 1e-9);
}

TEST(LabelVim, SphereMisclassifiedVolumeFallsUnderRefinement) {
  // Label 2 inside a ball of radius 1 in [0,3]^3 (40^3 voxels), label 1 outside.
  const long n = 40;
  Image<3> img = cube_labels(n, 3.0 / n, 1.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if ((img.point_of(img.index_of(k)) - Eigen::Vector3d(1.5, 1.5, 1.5)).norm() <= 1.0) img.data[k] = 2.0f;
  double mis[2];
  const long nodes[2] = {1000, 8000};
  for (int i = 0; i < 2; ++i) {
    const VimResult<3> r = optimize_labels<3>(img, grid_of(img, nodes[i]), VimOptions{});
    const LabelFit f = fit_of(img, r);
    mis[i] = f.misclassified;
    std::printf("sphere @%ld nodes: misclassified volume %.4f (sphere %.4f), %zu cells\n", nodes[i], mis[i],
                4.0 / 3.0 * M_PI, r.mesh.n_cells());
    EXPECT_EQ(f.wrong_majority, 0) << nodes[i] << " nodes";
    EXPECT_LE(mesh_quality<3>(r.mesh).max_dihedral_deg, 150.0 + 1e-9);
  }
  EXPECT_GT(mis[0], 0.0);
  EXPECT_GE(mis[0], 3.0 * mis[1]);  // 8000 nodes on 40^3 voxels may fit every voxel (0)
}

}  // namespace
}  // namespace vim

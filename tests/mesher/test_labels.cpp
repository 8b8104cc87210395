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

#include "label_images.hpp"
#include "label_truth.hpp"

namespace vim {
namespace {

// Three labels (1, 2, 7) in slabs and a ball: the label values are not equally spaced, so the variance
// of the values differs from the summed indicator variances.
Image<3> three_labels(long n) {
  Image<3> img = test::cube_labels(n, 1.0, 1.0f);
  const Eigen::Vector3d c(0.45 * n, 0.55 * n, 0.5 * n);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto p = img.point_of(img.index_of(k));
    if (p[0] > 0.6 * n) img.data[k] = 2.0f;
    if ((p - c).norm() < 0.3 * n) img.data[k] = 7.0f;
  }
  return img;
}

TEST(LabelStatistics, IndicatorVarianceAndMajorityMatchBruteForce) {
  const Image<3> img = three_labels(16);
  const LabelStatistics<3> stats(img);
  ASSERT_EQ(stats.labels(), (std::vector<int>{1, 2, 7}));
  // A grid moved at random (no node crosses a neighbour), so faces cut the voxels generically.
  SimplexMesh<3> mesh = test::grid_of(img, 343);
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
  Image<3> img = test::cube_labels(4, 1.0, 1.0f);
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
  const VimOptimizer<3> opt(test::grid_of(img, 216), &stats.values(), nullptr, o, &stats);
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

// The label fit of a VIM result; every voxel centre lies in the mesh.
test::LabelFit fit_of(const Image<3>& img, const VimResult<3>& r) {
  const test::LabelFit f = test::label_fit(img, r.mesh, r.labels);
  EXPECT_EQ(f.outside, 0) << "voxel centres outside the mesh";
  return f;
}

TEST(LabelVim, PlaneThroughVoxelFacesIsFollowedExactly) {
  // Labels 3 (x index ≤ 9) and 5: the interface is the plane of voxel faces x = 10 (spacing 1),
  // which the 10×10×10 grid (node planes at x ≈ 8.9, 11.1) does not contain.
  Image<3> img = test::cube_labels(20, 1.0, 3.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if (img.index_of(k)[0] >= 10) img.data[k] = 5.0f;
  const SimplexMesh<3> grid = test::grid_of(img, 1000);
  ASSERT_EQ(grid.n_points(), 1000u);
  VimResult<3> before;
  before.mesh = grid;
  const LabelStatistics<3> stats(img);
  for (std::size_t c = 0; c < grid.n_cells(); ++c)
    before.labels.push_back(stats.majority(cell_points(grid, c)));
  const test::LabelFit f0 = fit_of(img, before);
  const VimResult<3> r = optimize_labels<3>(img, grid, VimOptions{});
  const test::LabelFit f = fit_of(img, r);
  const MeshQuality q = mesh_quality<3>(r.mesh);
  std::printf("plane: misclassified volume grid %.1f, VIM %.1f; max dihedral %.1f\n", f0.misclassified,
              f.misclassified, q.max_dihedral_deg);
  EXPECT_GT(f0.misclassified, 0.0);
  EXPECT_EQ(f.misclassified, 0.0);
  EXPECT_EQ(f.wrong_majority, 0);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_LE(q.max_dihedral_deg, 150.0 + 1e-9);
}

}  // namespace
}  // namespace vim

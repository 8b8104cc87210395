// VIM on a label image under refinement (docs/labels.md): the misclassified volume of a ball falls
// with the node count. Truth: the independent voxel-centre classification of
// tests/support/label_truth.hpp. A refinement study (1,000 and 8,000 nodes), so it runs in the
// optimised build; the mesher suite's label tests run the same code under the sanitizers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

#include "label_images.hpp"
#include "label_truth.hpp"

namespace vim {
namespace {

TEST(LabelVim, SphereMisclassifiedVolumeFallsUnderRefinement) {
  // Label 2 inside a ball of radius 1 in [0,3]^3 (40^3 voxels), label 1 outside.
  const long n = 40;
  Image<3> img = test::cube_labels(n, 3.0 / n, 1.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if ((img.point_of(img.index_of(k)) - Eigen::Vector3d(1.5, 1.5, 1.5)).norm() <= 1.0) img.data[k] = 2.0f;
  double mis[2];
  const long nodes[2] = {1000, 8000};
  for (int i = 0; i < 2; ++i) {
    const VimResult<3> r = optimize_labels<3>(img, test::grid_of(img, nodes[i]), VimOptions{});
    const test::LabelFit f = test::label_fit(img, r.mesh, r.labels);
    EXPECT_EQ(f.outside, 0) << nodes[i] << " nodes";
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

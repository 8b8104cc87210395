// Determinism with node insertion on: nodes of one colour class share no element and insertion and
// swaps run sequentially in a fixed order, so the mesh (every coordinate bit), the cells and the
// energy history are identical at 1, 2, 4 and 8 threads. Truth: the 1-thread run (brute-force
// comparison, bit for bit), plus the check that insertion did add nodes.
#include <gtest/gtest.h>

#include <vim/initial_mesh.hpp>
#include <vim/vim.hpp>

#include "optimizer_test_util.hpp"

namespace vim {
namespace {

TEST(DeterminismInsertion, SameMeshAtOneTwoFourEightThreads3D) {
  const Image<3> img = testing::sphere_phantom(24);
  const auto initial = regular_grid_mesh<3>(img.box_min(), img.box_max(), {13, 13, 13});  // 2197 nodes
  VimOptions o;
  o.max_iterations = 3;
  o.insert_nodes = 40;
  o.node_budget = 2300;
  o.threads = 1;
  const auto one = optimize<3>(img, initial, o);
  ASSERT_GT(one.mesh.n_points(), initial.n_points()) << "insertion added no node";
  for (int threads : {2, 4, 8}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    o.threads = threads;
    const auto r = optimize<3>(img, initial, o);
    ASSERT_EQ(r.mesh.n_points(), one.mesh.n_points());
    for (std::size_t i = 0; i < r.mesh.n_points(); ++i)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(r.mesh.points[i][k], one.mesh.points[i][k]) << "node " << i;
    EXPECT_EQ(r.mesh.cells, one.mesh.cells);
    ASSERT_EQ(r.history.size(), one.history.size());
    for (std::size_t t = 0; t < r.history.size(); ++t) EXPECT_EQ(r.history[t].energy, one.history[t].energy);
  }
}

}  // namespace
}  // namespace vim

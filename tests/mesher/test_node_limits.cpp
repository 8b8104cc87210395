// Node limits. Truth: the key layout (3D facet keys pack three 21-bit node ids, so 2^21 = 2097152
// nodes is the most whose keys cannot collide) and arithmetic on the grid size ((1/h + 1)^3 nodes
// for spacing h on a unit cube, compared with the 2^31 - 1 int node ids).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vim/adjacency.hpp>
#include <vim/initial_mesh.hpp>

namespace vim {
namespace {

TEST(NodeLimits, AdjacencyRefusesANodeBeyondTheKeyRange3D) {
  EXPECT_EQ(Adjacency<3>::max_points(), std::size_t(1) << 21);
  Adjacency<3> adj;
  adj.build(Adjacency<3>::max_points() - 1, {});
  adj.add_point();  // the 2097152nd node still has a unique key
  EXPECT_EQ(adj.n_points(), std::size_t(1) << 21);
  try {
    adj.add_point();
    FAIL() << "node 2097153 accepted";
  } catch (const std::length_error& e) {
    EXPECT_NE(std::string(e.what()).find("2097152"), std::string::npos) << e.what();
  }
  EXPECT_EQ(adj.n_points(), std::size_t(1) << 21);  // unchanged by the refused node
  EXPECT_THROW(adj.build((std::size_t(1) << 21) + 1, {}), std::invalid_argument);
}

TEST(NodeLimits, TinySpacingIsRefusedInsteadOfOverflowing) {
  const Eigen::Vector3d lo(0, 0, 0), hi(1, 1, 1);
  // h = 1e-3: 1001^3 ≈ 1.0e9 nodes, still below 2^31 - 1.
  const auto ok = nodes_per_axis_for_spacing<3>(lo, hi, 1e-3);
  EXPECT_EQ(ok[0], 1001);
  // h = 1e-4: 10001^3 ≈ 1.0e12 nodes; h = 1e-300: each axis capped at 1e9 + 1, 1e27 nodes.
  for (double h : {1e-4, 1e-300}) {
    try {
      nodes_per_axis_for_spacing<3>(lo, hi, h);
      FAIL() << "spacing " << h << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("spacing"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("2147483647"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(regular_grid_mesh<3>(lo, hi, {100000, 100000, 100000}), std::invalid_argument);
}

}  // namespace
}  // namespace vim

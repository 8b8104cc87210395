// Determinism of the parallel node updates (paper §IV-B): nodes of one colour class
// share no element, so results are bit-identical for 1 and 2 threads, for both strategies, and for
// repeated runs with the same seed.
#include "optimizer_test_util.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/vim.hpp>

#include <gtest/gtest.h>

namespace vim {
namespace {

template <int dim>
void expect_identical(const VimResult<dim>& a, const VimResult<dim>& b) {
  ASSERT_EQ(a.mesh.n_points(), b.mesh.n_points());
  for (std::size_t i = 0; i < a.mesh.n_points(); ++i)
    for (int k = 0; k < dim; ++k) ASSERT_EQ(a.mesh.points[i][k], b.mesh.points[i][k]) << "node " << i;
  EXPECT_EQ(a.mesh.cells, b.mesh.cells);
  ASSERT_EQ(a.history.size(), b.history.size());
  for (std::size_t t = 0; t < a.history.size(); ++t) EXPECT_EQ(a.history[t].energy, b.history[t].energy);
}

template <int dim>
void check_threads(const Image<dim>& img, int nodes, VimOptions o) {
  std::array<int, dim> n;
  n.fill(nodes);
  const auto mesh = regular_grid_mesh<dim>(img.box_min(), img.box_max(), n);
  o.max_iterations = 4;
  o.threads = 1;
  const auto one = optimize<dim>(img, mesh, o);
  o.threads = 2;
  const auto two = optimize<dim>(img, mesh, o);
  const auto again = optimize<dim>(img, mesh, o);
  EXPECT_GT(one.history.back().v + one.history[1].v, 0.0);  // nodes did move
  expect_identical(one, two);
  expect_identical(two, again);
}

TEST(Determinism, OneVsTwoThreads3D) { check_threads<3>(testing::sphere_phantom(24), 5, VimOptions{}); }

TEST(Determinism, OneVsTwoThreadsRandomWalk2D) {
  VimOptions o;
  o.strategy = VimOptions::NodeStrategy::random_walk;
  o.seed = 12345;
  check_threads<2>(testing::two_circle_phantom(64), 8, o);
}

}  // namespace
}  // namespace vim

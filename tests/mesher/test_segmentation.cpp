// Tests of the segmentation of paper §VI-B: thresholded element means, facet-connected components
// (a shared vertex is not a connection), the largest component as the object, tie and edge cases.
#include <vim/initial_mesh.hpp>
#include <vim/segmentation.hpp>

#include <gtest/gtest.h>

namespace vim {
namespace {

std::vector<ElementValue> means(const std::vector<double>& m) {
  std::vector<ElementValue> v(m.size());
  for (std::size_t i = 0; i < m.size(); ++i) v[i].mean = m[i];
  return v;
}

TEST(Segmentation, TwoBlobsOnGrid2D) {
  // 6 × 3 squares, 2 triangles each; cell index = 2·(square) + k, square = i + 6 j.
  const auto mesh = regular_grid_mesh<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(6, 3), {7, 4});
  ASSERT_EQ(mesh.n_cells(), 36u);
  std::vector<double> m(36, 0.0);
  long blob_a = 0, blob_b = 0;
  for (int c = 0; c < 36; ++c) {
    const int col = (c / 2) % 6;
    if (col == 4) {  // one column: 6 cells
      m[c] = 2.0;
      ++blob_b;
    }
    if (col <= 1) {  // two columns: 12 cells
      m[c] = 3.0;
      ++blob_a;
    }
  }
  const auto s = segment<2>(mesh, means(m), 1.5);
  EXPECT_EQ(s.n_components, 2);
  EXPECT_EQ(s.largest, s.component[0]);
  EXPECT_EQ(s.largest_size, blob_a);
  EXPECT_EQ(blob_a, 12);
  EXPECT_EQ(blob_b, 6);
  for (int c = 0; c < 36; ++c) {
    const int col = (c / 2) % 6;
    EXPECT_EQ(s.object[c], col <= 1) << c;
    EXPECT_EQ(s.component[c] >= 0, m[c] > 1.5) << c;
    if (col == 4) {
      EXPECT_EQ(s.component[c], s.component[9]);  // cell 9 is in column 4
    }
  }
  // Raising the threshold to 2 keeps only blob A (strictly greater).
  const auto t = segment<2>(mesh, means(m), 2.0);
  EXPECT_EQ(t.n_components, 1);
  EXPECT_EQ(t.largest_size, 12);
}

TEST(Segmentation, VertexContactDoesNotConnect) {
  // Two triangles sharing only vertex 2, plus a third sharing an edge with the first.
  SimplexMesh<2> mesh;
  mesh.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(1, 1), Eigen::Vector2d(2, 1),
                 Eigen::Vector2d(2, 2), Eigen::Vector2d(0, 1)};
  mesh.cells = {{0, 1, 2}, {2, 3, 4}, {0, 2, 5}};
  const auto s = segment<2>(mesh, means({1, 1, 1}), 0.5);
  EXPECT_EQ(s.n_components, 2);
  EXPECT_EQ(s.component[0], s.component[2]);
  EXPECT_NE(s.component[0], s.component[1]);
  EXPECT_EQ(s.largest_size, 2);
  EXPECT_EQ(s.object, (std::vector<bool>{true, false, true}));
}

TEST(Segmentation, TieGoesToSmallestIdAndNothingAboveThreshold) {
  SimplexMesh<2> mesh;
  mesh.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(1, 1), Eigen::Vector2d(2, 1),
                 Eigen::Vector2d(2, 2)};
  mesh.cells = {{0, 1, 2}, {2, 3, 4}};
  const auto s = segment<2>(mesh, means({1, 1}), 0.5);
  EXPECT_EQ(s.n_components, 2);
  EXPECT_EQ(s.largest, 0);
  EXPECT_EQ(s.object, (std::vector<bool>{true, false}));
  const auto none = segment<2>(mesh, means({1, 1}), 5.0);
  EXPECT_EQ(none.n_components, 0);
  EXPECT_EQ(none.largest, -1);
  EXPECT_EQ(none.component, (std::vector<int>{-1, -1}));
  EXPECT_EQ(none.object, (std::vector<bool>{false, false}));
  EXPECT_THROW(segment<2>(mesh, means({1}), 0.5), std::invalid_argument);
}

TEST(Segmentation, TwoBoxesOnGrid3D) {
  // 6 × 4 × 4 cubes of 6 tets; box A = cubes x∈[0,2), y,z∈[0,2) (8 cubes); box B = cubes x∈[4,6),
  // y∈[1,4), z∈[0,4) (24 cubes). Cells are selected by centroid, so each box is whole cubes.
  const auto mesh = regular_grid_mesh<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(6, 4, 4), {7, 5, 5});
  std::vector<double> m(mesh.n_cells(), 0.0);
  std::vector<int> truth(mesh.n_cells(), -1);
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = centroid<3>(cell_points(mesh, c));
    if (x[0] < 2 && x[1] < 2 && x[2] < 2) truth[c] = 0, m[c] = 5.0;
    if (x[0] > 4 && x[1] > 1) truth[c] = 1, m[c] = 5.0;
  }
  const auto s = segment<3>(mesh, means(m), 1.0);
  EXPECT_EQ(s.n_components, 2);
  EXPECT_EQ(s.largest_size, 24 * 6);
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    EXPECT_EQ(s.object[c], truth[c] == 1);
    EXPECT_EQ(s.component[c] >= 0, truth[c] >= 0);
  }
}

}  // namespace
}  // namespace vim

namespace vim {
namespace {
// "The largest component" is the largest by volume: on an adaptive mesh a few big elements can
// outweigh many small ones (a real CT at 2500 nodes: 7 cells of volume 6246 against 8 of 5660).
TEST(Segmentation, LargestComponentIsLargestByVolume) {
  SimplexMesh<2> mesh;
  // Four small triangles (unit square fan, area 0.25 each) and, far away, two big ones (area 8 each).
  mesh.points = {Eigen::Vector2d(0, 0),  Eigen::Vector2d(1, 0),  Eigen::Vector2d(1, 1),  Eigen::Vector2d(0, 1),
                 Eigen::Vector2d(0.5, 0.5), Eigen::Vector2d(10, 0), Eigen::Vector2d(14, 0), Eigen::Vector2d(14, 4),
                 Eigen::Vector2d(10, 4)};
  mesh.cells = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {5, 6, 7}, {5, 7, 8}};
  std::vector<ElementValue> v(6);
  for (auto& e : v) e.mean = 2.0;
  const auto s = segment<2>(mesh, v, 1.0);
  EXPECT_EQ(s.n_components, 2);
  EXPECT_EQ(s.largest, s.component[4]);
  EXPECT_EQ(s.largest_size, 2);
  EXPECT_DOUBLE_EQ(s.largest_volume, 16.0);
  for (int c = 0; c < 6; ++c) EXPECT_EQ(s.object[c], c >= 4) << c;
}
}  // namespace
}  // namespace vim

// Tests of the Image<dim> view (index ↔ physical point, linear indexing, voxel box, multilinear
// interpolation) and the SimplexMesh<dim> helpers (signed volume, orientation, centroid) against
// hand-computed values in 2D and 3D.
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

#include <gtest/gtest.h>

#include <random>

namespace vim {
namespace {

TEST(Image, IndexPointRoundTrip3D) {
  Image<3> img({4, 3, 5}, {0.5, 2.0, 3.0}, {-1.0, 10.0, 0.25});
  EXPECT_EQ(img.voxel_count(), 60u);
  EXPECT_EQ(img.linear_index({1, 0, 0}), 1u);
  EXPECT_EQ(img.linear_index({0, 1, 0}), 4u);
  EXPECT_EQ(img.linear_index({0, 0, 1}), 12u);
  EXPECT_EQ(img.linear_index({3, 2, 4}), 59u);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) EXPECT_EQ(img.linear_index(img.index_of(k)), k);
  const auto p = img.point_of({3, 2, 4});
  EXPECT_DOUBLE_EQ(p[0], -1.0 + 1.5);
  EXPECT_DOUBLE_EQ(p[1], 14.0);
  EXPECT_DOUBLE_EQ(p[2], 12.25);
  const auto c = img.continuous_index(p);
  EXPECT_NEAR(c[0], 3.0, 1e-14);
  EXPECT_NEAR(c[1], 2.0, 1e-14);
  EXPECT_NEAR(c[2], 4.0, 1e-14);
  EXPECT_DOUBLE_EQ(img.box_min()[0], -1.25);
  EXPECT_DOUBLE_EQ(img.box_max()[0], -1.0 + 3.5 * 0.5);
  EXPECT_DOUBLE_EQ(img.box_min()[2], 0.25 - 1.5);
  EXPECT_DOUBLE_EQ(img.box_max()[1], 10.0 + 2.5 * 2.0);
  EXPECT_DOUBLE_EQ(img.min_spacing(), 0.5);
  img.at({2, 1, 3}) = 7.0f;
  EXPECT_EQ(img.data[2 + 4 * (1 + 3 * 3)], 7.0f);
}

template <int dim>
void expect_linear_reproduced() {
  std::array<long, dim> size;
  std::array<double, dim> sp, org;
  for (int a = 0; a < dim; ++a) {
    size[a] = 4 + a;
    sp[a] = 0.3 + 0.4 * a;
    org[a] = -2.0 + a;
  }
  Image<dim> img(size, sp, org);
  Eigen::Matrix<double, dim, 1> g;
  for (int a = 0; a < dim; ++a) g[a] = 1.5 - a;
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    img.data[k] = static_cast<float>(3.0 + g.dot(img.point_of(img.index_of(k))));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int t = 0; t < 200; ++t) {
    Eigen::Matrix<double, dim, 1> p;  // inside the hull of the voxel centres
    for (int a = 0; a < dim; ++a) p[a] = org[a] + u(rng) * (size[a] - 1) * sp[a];
    EXPECT_NEAR(img.interpolate(p), 3.0 + g.dot(p), 1e-5);  // float storage
  }
  // Outside: clamped to the nearest centre.
  Eigen::Matrix<double, dim, 1> far = img.point_of(std::array<long, dim>{});
  far[0] -= 10.0;
  EXPECT_NEAR(img.interpolate(far), img.data[0], 1e-6);
}

TEST(Image, InterpolationReproducesLinearFunctions) {
  expect_linear_reproduced<2>();
  expect_linear_reproduced<3>();
}

TEST(SimplexMesh, SignedVolumesAndOrientation2D) {
  SimplexMesh<2> mesh;
  mesh.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 0), Eigen::Vector2d(0, 3), Eigen::Vector2d(2, 3)};
  mesh.cells = {{0, 1, 2}, {1, 2, 3}};  // ccw (+3), cw (−3)
  EXPECT_DOUBLE_EQ(signed_volume(mesh, 0), 3.0);
  EXPECT_DOUBLE_EQ(signed_volume(mesh, 1), -3.0);
  EXPECT_DOUBLE_EQ(total_volume(mesh), 6.0);
  EXPECT_EQ(orient_positively(mesh), 1u);
  EXPECT_DOUBLE_EQ(signed_volume(mesh, 1), 3.0);
  EXPECT_EQ(orient_positively(mesh), 0u);
  const auto c = centroid<2>(cell_points(mesh, 0));
  EXPECT_DOUBLE_EQ(c[0], 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(c[1], 1.0);
}

TEST(SimplexMesh, SignedVolumesAndOrientation3D) {
  SimplexMesh<3> mesh;
  mesh.points = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0),
                 Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(2, 2, 2)};
  mesh.cells = {{0, 1, 2, 3}, {1, 0, 2, 3}, {1, 2, 3, 4}};
  EXPECT_NEAR(signed_volume(mesh, 0), 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(signed_volume(mesh, 1), -1.0 / 6.0, 1e-15);
  // (1,0,0),(0,1,0),(0,0,1),(2,2,2): edge vectors (−1,1,0), (−1,0,1), (1,2,2) as columns;
  // det = c1·(c2 × c3) = (−1,1,0)·(−2,3,−2) = 5 → volume 5/6.
  EXPECT_NEAR(signed_volume(mesh, 2), 5.0 / 6.0, 1e-14);
  EXPECT_NEAR(total_volume(mesh), 1.0 / 6.0 + 1.0 / 6.0 + 5.0 / 6.0, 1e-14);
  EXPECT_EQ(orient_positively(mesh), 1u);
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) EXPECT_GT(signed_volume(mesh, c), 0.0);
}

}  // namespace
}  // namespace vim

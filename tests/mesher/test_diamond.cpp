// Paper Fig. 3 (§III-C): a four-triangle mesh of the unit square with one free centre node over a
// diamond-shaped feature. For λ = 0.8 the node moves from the centre out to a corner of the diamond
// and to the minimiser of E found by a brute-force scan of node positions (which lies on the ray
// through the corner, ≈0.06 beyond it: the three large triangles' variance keeps falling until the
// geometric term stops it); for λ ≈ 0 a node started off the centre comes back to the scanned minimiser
// at the centre.
#include <gtest/gtest.h>

#include <limits>
#include <vim/vim.hpp>

#include "optimizer_test_util.hpp"

namespace vim {
namespace {

constexpr double kRadius = 0.3;  // diamond |x − 0.5| + |y − 0.5| <= 0.3

Image<2> diamond_image() {
  return testing::phantom<2>(100, 1.0, [](const Eigen::Vector2d& p) {
    return std::abs(p[0] - 0.5) + std::abs(p[1] - 0.5) <= kRadius;
  });
}

SimplexMesh<2> four_triangles(const Eigen::Vector2d& centre) {
  SimplexMesh<2> m;
  m.points = {{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}, centre};
  m.cells = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  return m;
}

// Offset of p from the nearest ray centre → diamond corner (the lines x = 0.5, y = 0.5).
double off_corner_rays(const Eigen::Vector2d& p) {
  return std::min(std::abs(p[0] - 0.5), std::abs(p[1] - 0.5));
}
double from_centre(const Eigen::Vector2d& p) { return (p - Eigen::Vector2d(0.5, 0.5)).norm(); }

VimResult<2> run(double lambda) {
  VimOptions o;
  o.lambda = lambda;
  o.swaps = false;  // Fig. 3 keeps the triangulation fixed
  o.max_iterations = 20;
  return optimize<2>(diamond_image(), four_triangles({0.5, 0.5}), o);
}

TEST(Diamond, LargeLambdaMovesCentreNodeToADiamondCorner) {
  const auto r = run(0.8);
  const Eigen::Vector2d p = r.mesh.points[4];
  EXPECT_LT(off_corner_rays(p), 0.01) << p.transpose();
  EXPECT_GE(from_centre(p), kRadius - 0.01) << "did not reach the diamond corner: " << p.transpose();
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.mesh.points[i], four_triangles({0.5, 0.5}).points[i]);

  // Independent truth: brute-force scan of E (Eq. 7, per-voxel enumeration) over node positions.
  const auto img = diamond_image();
  const auto e0 = testing::brute_force_energy(img, four_triangles({0.5, 0.5}));
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d arg(0.5, 0.5);
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const Eigen::Vector2d q(0.1 + 0.02 * i, 0.1 + 0.02 * j);
      const double e = testing::brute_force_energy(img, four_triangles(q)).combined(e0.eg, e0.ed, 0.8);
      if (e < best) {
        best = e;
        arg = q;
      }
    }
  EXPECT_LT(off_corner_rays(arg), 0.01) << "scan minimiser " << arg.transpose();
  EXPECT_NEAR(from_centre(p), from_centre(arg), 0.03) << "scan minimiser " << arg.transpose();
  const double found = testing::brute_force_energy(img, r.mesh).combined(e0.eg, e0.ed, 0.8);
  EXPECT_LT(found, 1.0);
  EXPECT_LE(found, best + 0.02) << "the optimiser stopped far above the scanned minimum";
}

// Started off the optimum, at (0.62, 0.41): the optimiser must bring the node to the minimiser of a
// brute-force scan of E over node positions (step 0.005, half a voxel), which for λ ≈ 0 lies at the
// centre (the ODT optimum of four triangles on a square; the diamond is symmetric about it).
TEST(Diamond, SmallLambdaBringsAnOffCentreNodeToTheScannedOptimum) {
  const double lambda = 0.01;
  const Eigen::Vector2d start(0.62, 0.41);
  VimOptions o;
  o.lambda = lambda;
  o.swaps = false;
  o.max_iterations = 20;
  const auto img = diamond_image();
  const auto r = optimize<2>(img, four_triangles(start), o);
  const Eigen::Vector2d p = r.mesh.points[4];

  const auto e0 = testing::brute_force_energy(img, four_triangles(start));  // E_G0, E_D0 of the start
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d arg = start;
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const Eigen::Vector2d q(0.4 + 0.005 * i, 0.4 + 0.005 * j);
      const double e = testing::brute_force_energy(img, four_triangles(q)).combined(e0.eg, e0.ed, lambda);
      if (e < best) best = e, arg = q;
    }
  EXPECT_LT((arg - Eigen::Vector2d(0.5, 0.5)).norm(), 0.011) << "scan minimiser " << arg.transpose();
  EXPECT_LT((p - arg).norm(), 0.011) << p.transpose() << " vs scan minimiser " << arg.transpose();
  const double found = testing::brute_force_energy(img, r.mesh).combined(e0.eg, e0.ed, lambda);
  EXPECT_LE(found, best + 1e-3 * best) << "the optimiser stopped above the scanned minimum";
}

}  // namespace
}  // namespace vim

// Tests of the element quality measures behind the paper's quality bound (§IV) and statistics (§VI):
// hand-computed dihedral / interior angles and normalised radius ratios, the acceptability rule,
// and the mesh summary on a Kuhn grid.
#include <vim/initial_mesh.hpp>
#include <vim/optimizer.hpp>
#include <vim/quality.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace vim {
namespace {

using T2 = std::array<Eigen::Vector2d, 3>;
using T3 = std::array<Eigen::Vector3d, 4>;

// Moves vertex `moving` of the simplex x along d until the predicate `outside` (on the moved
// simplex) changes, locates the crossing by bisection, and calls `visit` on the positive simplices
// 1e-3 … 1e-13 before and after it, and at it. Does nothing if `outside` does not change for t ≤ 2.
template <class S, class V, class Outside, class Visit>
void visit_near_bound(const S& x, int moving, const V& d, Outside&& outside, Visit&& visit) {
  constexpr int dim = static_cast<int>(std::tuple_size<S>::value) - 1;
  auto moved = [&](double t) {
    S y = x;
    y[moving] += t * d;
    return y;
  };
  const bool o0 = outside(moved(0.0));
  double lo = 0.0, hi = 0.0;
  for (double t = 0.05; t <= 2.0 && hi == 0.0; t += 0.05)
    if (outside(moved(t)) != o0) hi = t;
  if (hi == 0.0) return;
  for (int it = 0; it < 200 && hi - lo > 1e-15; ++it) {
    const double mid = 0.5 * (lo + hi);
    (outside(moved(mid)) == o0 ? lo : hi) = mid;
  }
  for (double delta : {-1e-3, -1e-7, -1e-10, -1e-13, 0.0, 1e-13, 1e-10, 1e-7, 1e-3}) {
    const S y = moved(lo + delta);
    if (signed_volume<dim>(y) > 0.0) visit(y);
  }
}

const double kRad = 180.0 / M_PI;

TEST(Quality, RegularTetrahedron) {
  const T3 x{Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(1, -1, -1), Eigen::Vector3d(-1, 1, -1),
             Eigen::Vector3d(-1, -1, 1)};
  for (double a : dihedral_angles_deg<3>(x)) EXPECT_NEAR(a, std::acos(1.0 / 3.0) * kRad, 1e-10);  // 70.5288°
  EXPECT_NEAR(max_dihedral_deg<3>(x), 70.528779365509308, 1e-9);
  EXPECT_NEAR(normalized_radius_ratio<3>(x), 1.0, 1e-12);
}

TEST(Quality, KuhnTetrahedron) {
  // Path 0 → e_x → e_x+e_y → e_x+e_y+e_z. Outward face normals (by hand): opp 0: (1,0,0);
  // opp 1: (−1,1,0)/√2; opp 2: (0,−1,1)/√2; opp 3: (0,0,−1). Dihedral at edge (i,j) = 180° − the
  // angle between the normals of the two other faces: 45, 90, 60, 90, 90, 45.
  const T3 x{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(1, 1, 1)};
  const std::array<double, 6> expected{45, 90, 60, 90, 90, 45};
  const auto a = dihedral_angles_deg<3>(x);
  for (int e = 0; e < 6; ++e) EXPECT_NEAR(a[e], expected[e], 1e-10) << "edge " << e;
  EXPECT_NEAR(max_dihedral_deg<3>(x), 90.0, 1e-10);
  EXPECT_NEAR(min_dihedral_deg<3>(x), 45.0, 1e-10);
  // r_in = 3V/ΣA = (1/2)/(1+√2); R = √3/2 (the cube's circumsphere): NRR = √3/(1+√2).
  EXPECT_NEAR(normalized_radius_ratio<3>(x), std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-12);
  // Orientation does not matter for angles.
  T3 y = x;
  std::swap(y[0], y[1]);
  EXPECT_NEAR(max_dihedral_deg<3>(y), 90.0, 1e-10);
}

TEST(Quality, Triangles) {
  const T2 eq{Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 0), Eigen::Vector2d(1, std::sqrt(3.0))};
  for (double a : dihedral_angles_deg<2>(eq)) EXPECT_NEAR(a, 60.0, 1e-10);
  EXPECT_NEAR(normalized_radius_ratio<2>(eq), 1.0, 1e-12);
  // Right isosceles: angles 90/45/45, r_in = (2−√2)/2, R = √2/2 → NRR = 2√2 − 2.
  const T2 right{Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
  const auto a = dihedral_angles_deg<2>(right);
  EXPECT_NEAR(a[0], 90.0, 1e-10);
  EXPECT_NEAR(a[1], 45.0, 1e-10);
  EXPECT_NEAR(a[2], 45.0, 1e-10);
  EXPECT_NEAR(normalized_radius_ratio<2>(right), 2.0 * std::sqrt(2.0) - 2.0, 1e-12);
  // Angles sum to 180° for any triangle.
  const T2 odd{Eigen::Vector2d(0.3, -1), Eigen::Vector2d(4, 0.2), Eigen::Vector2d(-2, 3)};
  const auto b = dihedral_angles_deg<2>(odd);
  EXPECT_NEAR(b[0] + b[1] + b[2], 180.0, 1e-10);
}

TEST(Quality, Acceptable) {
  const T3 kuhn{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(1, 1, 1)};
  QualityBound b;
  EXPECT_TRUE(acceptable<3>(kuhn, b));
  T3 inverted = kuhn;
  std::swap(inverted[0], inverted[1]);
  EXPECT_FALSE(acceptable<3>(inverted, b));
  T3 flat = kuhn;
  flat[3] = Eigen::Vector3d(1, 1, 0) + 1e-14 * Eigen::Vector3d(0, 0, 1);
  EXPECT_FALSE(acceptable<3>(flat, b));
  b.max_dihedral_deg = 89.0;
  EXPECT_FALSE(acceptable<3>(kuhn, b));
  b = QualityBound{};
  b.min_dihedral_deg = 50.0;
  EXPECT_FALSE(acceptable<3>(kuhn, b));
  b = QualityBound{};
  b.min_radius_ratio = 0.75;  // Kuhn NRR ≈ 0.717
  EXPECT_FALSE(acceptable<3>(kuhn, b));
  b.min_radius_ratio = 0.7;
  EXPECT_TRUE(acceptable<3>(kuhn, b));
  // 2D: a needle triangle with a 170° angle violates the default 150° bound.
  const T2 needle{Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 0), Eigen::Vector2d(1, std::tan(5.0 / kRad))};
  EXPECT_FALSE(acceptable<2>(needle, QualityBound{}));
  const T2 right{Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
  EXPECT_TRUE(acceptable<2>(right, QualityBound{}));
}

TEST(Quality, MeshSummaryOfKuhnGrid) {
  auto mesh = regular_grid_mesh<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 2, 2), {3, 3, 3});
  auto q = mesh_quality<3>(mesh);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_NEAR(q.max_dihedral_deg, 90.0, 1e-9);
  EXPECT_NEAR(q.min_dihedral_deg, 45.0, 1e-9);
  EXPECT_NEAR(q.min_nrr, std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-12);
  std::swap(mesh.cells[5][0], mesh.cells[5][1]);
  EXPECT_EQ(mesh_quality<3>(mesh).inverted, 1);
  const auto q2 = mesh_quality<2>(regular_grid_mesh<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), {4, 4}));
  EXPECT_NEAR(q2.max_dihedral_deg, 90.0, 1e-9);
  EXPECT_NEAR(q2.min_dihedral_deg, 45.0, 1e-9);
}

// The optimiser's fast quality test (cosines, or squared cosines without square roots for a max
// bound alone, with or without the precomputed fixed face) must reach the decision of
// vim::acceptable on every tetrahedron: random ones, and ones whose largest dihedral angle sits within
// 1e-3 … 1e-13 of the bound (found by bisection on the exact angle, or on the exact normalised
// radius ratio for the cases with a ratio bound, which the optimiser decides by closed forms).
TEST(Quality, OptimizerFastTestAgreesWithReference) {
  struct Case {
    double max_deg, min_deg, min_rr;
  };
  const Case cases[] = {{150.0, 0.0, 0.0}, {120.0, 0.0, 0.0}, {95.0, 0.0, 0.0},
                        {150.0, 12.0, 0.0}, {150.0, 0.0, 0.3}, {150.0, 10.0, 0.2}};
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random_point = [&] { return Eigen::Vector3d(u(rng), u(rng), u(rng)); };
  for (const Case& cs : cases) {
    VimOptions o;
    o.max_dihedral_deg = cs.max_deg;
    o.min_dihedral_deg = cs.min_deg;
    o.min_radius_ratio = cs.min_rr;
    VimOptimizer<3> opt(regular_grid_mesh<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), {2, 2, 2}),
                        nullptr, nullptr, o);
    QualityBound b;
    b.max_dihedral_deg = cs.max_deg;
    b.min_dihedral_deg = cs.min_deg;
    b.min_radius_ratio = cs.min_rr;
    long checked = 0, accepted = 0, near = 0;
    auto check = [&](const T3& x, int moving) {
      const double vol = signed_volume<3>(x);
      const bool want = acceptable<3>(x, b);
      const FixedFace<3> face = fixed_face<3>(x, moving);
      ASSERT_EQ(opt.acceptable(x, vol), want) << "bound " << cs.max_deg << "/" << cs.min_deg << "/" << cs.min_rr;
      ASSERT_EQ(opt.acceptable(x, vol, &face), want) << "bound " << cs.max_deg << "/" << cs.min_deg << "/" << cs.min_rr;
      ++checked;
      accepted += want;
    };
    for (int trial = 0; trial < 4000; ++trial) {
      T3 x{random_point(), random_point(), random_point(), random_point()};
      if (signed_volume<3>(x) < 0.0) std::swap(x[0], x[1]);
      const int moving = trial % 4;
      check(x, moving);
      // Move one vertex along a random direction until the largest angle (or the ratio) crosses the bound.
      auto outside = [&](const T3& y) {
        if (!(signed_volume<3>(y) > 0.0)) return true;
        return cs.min_rr > 0.0 ? normalized_radius_ratio<3>(y) < cs.min_rr : max_dihedral_deg<3>(y) > cs.max_deg;
      };
      visit_near_bound(x, moving, random_point(), outside, [&](const T3& y) {
        check(y, moving);
        ++near;
      });
    }
    // Both decisions occur, and many tetrahedra sit at the bound.
    EXPECT_GT(accepted, checked / 20) << cs.max_deg;
    EXPECT_LT(accepted, checked - checked / 20) << cs.max_deg;
    EXPECT_GT(near, 1000) << cs.max_deg;
  }
}

// 2D: the optimiser's closed-form radius-ratio test reaches vim::acceptable's decision on random
// triangles and on triangles whose ratio sits within 1e-3 … 1e-13 of the bound.
TEST(Quality, OptimizerRadiusRatioTestAgreesWithReference2D) {
  std::mt19937_64 rng(20261124);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random_point = [&] { return Eigen::Vector2d(u(rng), u(rng)); };
  for (double rr : {0.2, 0.5, 0.8}) {
    VimOptions o;
    o.min_radius_ratio = rr;
    VimOptimizer<2> opt(regular_grid_mesh<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), {2, 2}), nullptr, nullptr, o);
    QualityBound b;
    b.min_radius_ratio = rr;
    long checked = 0, accepted = 0, near = 0;
    auto check = [&](const std::array<Eigen::Vector2d, 3>& x) {
      const bool want = acceptable<2>(x, b);
      ASSERT_EQ(opt.acceptable(x, signed_volume<2>(x)), want) << "bound " << rr;
      ++checked;
      accepted += want;
    };
    for (int trial = 0; trial < 4000; ++trial) {
      std::array<Eigen::Vector2d, 3> x{random_point(), random_point(), random_point()};
      if (signed_volume<2>(x) < 0.0) std::swap(x[0], x[1]);
      check(x);
      using T2 = std::array<Eigen::Vector2d, 3>;
      auto outside = [&](const T2& y) { return !(signed_volume<2>(y) > 0.0) || normalized_radius_ratio<2>(y) < rr; };
      visit_near_bound(x, trial % 3, random_point(), outside, [&](const T2& y) {
        check(y);
        ++near;
      });
    }
    EXPECT_GT(accepted, checked / 20) << rr;
    EXPECT_LT(accepted, checked - checked / 20) << rr;
    EXPECT_GT(near, 1000) << rr;
  }
}

}  // namespace
}  // namespace vim

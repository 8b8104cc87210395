// Tests of the initial Kuhn/Freudenthal grid mesh (paper §IV-C, §VI): node counts from a budget or a
// spacing, conformity (every interior facet shared by exactly two cells), orientation, covered
// volume, node numbering and the boundary classification, in 2D and 3D.
#include <vim/initial_mesh.hpp>
#include <vim/quality.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace vim {
namespace {

TEST(InitialMesh, BudgetOnCube) {
  const Eigen::Vector3d lo(0, 0, 0), hi(3, 3, 3);
  EXPECT_EQ(nodes_per_axis_for_budget<3>(lo, hi, 125), (std::array<int, 3>{5, 5, 5}));
  EXPECT_EQ(nodes_per_axis_for_budget<3>(lo, hi, 343), (std::array<int, 3>{7, 7, 7}));
  EXPECT_EQ(nodes_per_axis_for_budget<3>(lo, hi, 4096), (std::array<int, 3>{16, 16, 16}));
  // Independent truth on a cube: the largest k with k³ ≤ budget.
  for (long budget = 8; budget < 3000; budget += 37) {
    long k = 2;
    while ((k + 1) * (k + 1) * (k + 1) <= budget) ++k;
    const auto n = nodes_per_axis_for_budget<3>(lo, hi, budget);
    EXPECT_EQ(n, (std::array<int, 3>{int(k), int(k), int(k)})) << budget;
  }
  EXPECT_EQ(nodes_per_axis_for_budget<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), 100),
            (std::array<int, 2>{10, 10}));
}

TEST(InitialMesh, BudgetOnElongatedBox) {
  // 4 × 2 × 1 box: cells ≈ cubic, count ≤ budget.
  const Eigen::Vector3d lo(0, 0, 0), hi(4, 2, 1);
  for (long budget : {8L, 50L, 300L, 2000L}) {
    const auto n = nodes_per_axis_for_budget<3>(lo, hi, budget);
    EXPECT_LE(long(n[0]) * n[1] * n[2], budget);
    for (int a = 0; a < 3; ++a) EXPECT_GE(n[a], 2);
    if (budget >= 300) {  // fine enough for the aspect ratio to show
      const double h0 = 4.0 / (n[0] - 1), h1 = 2.0 / (n[1] - 1), h2 = 1.0 / (n[2] - 1);
      EXPECT_LT(std::max({h0, h1, h2}) / std::min({h0, h1, h2}), 1.6) << budget;
    }
  }
  // By hand: h = 4/22 gives 23 × 12 × 7 = 1932 (1/h = 5.5 rounds up); h = 4/23 gives 24 × 13 × 7 = 2184.
  EXPECT_EQ(nodes_per_axis_for_budget<3>(lo, hi, 2000), (std::array<int, 3>{23, 12, 7}));
}

TEST(InitialMesh, BudgetErrors) {
  try {
    nodes_per_axis_for_budget<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), 7);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("nodes"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("8"), std::string::npos) << e.what();
  }
  EXPECT_THROW(nodes_per_axis_for_budget<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), 3), std::invalid_argument);
  EXPECT_THROW(nodes_per_axis_for_budget<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(0, 1), 100), std::invalid_argument);
  EXPECT_THROW(nodes_per_axis_for_spacing<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), 0.0), std::invalid_argument);
  EXPECT_THROW(regular_grid_mesh<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), {1, 3}), std::invalid_argument);
}

TEST(InitialMesh, Spacing) {
  EXPECT_EQ(nodes_per_axis_for_spacing<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 1.5), 0.5),
            (std::array<int, 2>{7, 4}));
  EXPECT_EQ(nodes_per_axis_for_spacing<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 10), 5.0),
            (std::array<int, 3>{2, 2, 3}));
}

template <int dim>
void expect_valid_grid(const Eigen::Matrix<double, dim, 1>& lo, const Eigen::Matrix<double, dim, 1>& hi,
                       const std::array<int, dim>& n) {
  const auto mesh = regular_grid_mesh<dim>(lo, hi, n);
  long nodes = 1, cubes = 1, fact = 1;
  for (int a = 0; a < dim; ++a) {
    nodes *= n[a];
    cubes *= n[a] - 1;
    fact *= a + 1;
  }
  ASSERT_EQ(static_cast<long>(mesh.n_points()), nodes);
  ASSERT_EQ(static_cast<long>(mesh.n_cells()), cubes * fact);
  // Numbering: axis 0 fastest.
  for (long k = 0; k < nodes; ++k) {
    long r = k;
    for (int a = 0; a < dim; ++a) {
      const long i = r % n[a];
      r /= n[a];
      EXPECT_NEAR(mesh.points[k][a], lo[a] + (hi[a] - lo[a]) * double(i) / (n[a] - 1), 1e-12);
    }
  }
  double volume = 0.0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const double v = signed_volume(mesh, c);
    EXPECT_GT(v, 0.0);
    volume += v;
  }
  EXPECT_NEAR(volume, (hi - lo).prod(), 1e-12 * (hi - lo).prod());
  // Conformity: interior facets in exactly 2 cells; boundary facets (all vertices on one box face)
  // in exactly 1; their number = 2 · Σ_a Π_{c≠a}(n_c − 1) · (dim−1)! simplices per boundary square.
  std::map<std::array<int, dim>, int> facets;
  for (const auto& cell : mesh.cells)
    for (int i = 0; i <= dim; ++i) {
      std::array<int, dim> f;
      for (int k = 0, m = 0; k <= dim; ++k)
        if (k != i) f[m++] = cell[k];
      std::sort(f.begin(), f.end());
      ++facets[f];
    }
  const auto kind = boundary_kind<dim>(mesh, lo, hi, 1e-12);
  long boundary = 0;
  for (const auto& [f, count] : facets) {
    bool on_face = false;
    for (int a = 0; a < dim && !on_face; ++a)
      for (double side : {lo[a], hi[a]}) {
        bool all = true;
        for (int v : f) all = all && std::abs(mesh.points[v][a] - side) < 1e-12;
        on_face = on_face || all;
      }
    EXPECT_EQ(count, on_face ? 1 : 2);
    boundary += on_face;
  }
  long expected_boundary = 0;
  for (int a = 0; a < dim; ++a) {
    long squares = 1;
    for (int c = 0; c < dim; ++c)
      if (c != a) squares *= n[c] - 1;
    expected_boundary += 2 * squares * (fact / dim);
  }
  EXPECT_EQ(boundary, expected_boundary);
  // Boundary kinds: count nodes with k box faces = Σ over choices of k axes on the boundary.
  std::array<long, dim + 1> by_kind{};
  for (auto k : kind) ++by_kind[k];
  std::array<long, dim + 1> expected{};
  for (int mask = 0; mask < (1 << dim); ++mask) {  // mask: axes at the boundary
    long count = 1;
    int k = 0;
    for (int a = 0; a < dim; ++a) {
      if (mask >> a & 1) {
        count *= 2;
        ++k;
      } else {
        count *= n[a] - 2;
      }
    }
    expected[k] += count;
  }
  EXPECT_EQ(by_kind, expected);
  bool cubes_equal = true;
  for (int a = 1; a < dim; ++a)
    cubes_equal = cubes_equal && std::abs((hi[a] - lo[a]) / (n[a] - 1) - (hi[0] - lo[0]) / (n[0] - 1)) < 1e-12;
  if (cubes_equal) {
    EXPECT_NEAR(mesh_quality<dim>(mesh).max_dihedral_deg, 90.0, 1e-9);
  }
}

TEST(InitialMesh, KuhnGrid2D) {
  expect_valid_grid<2>(Eigen::Vector2d(-1, 2), Eigen::Vector2d(3, 4), {5, 3});
  expect_valid_grid<2>(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1), {2, 2});
}

TEST(InitialMesh, KuhnGrid3D) {
  expect_valid_grid<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(3, 3, 3), {5, 5, 5});
  expect_valid_grid<3>(Eigen::Vector3d(-1, 0.5, 2), Eigen::Vector3d(2, 1.5, 2.7), {4, 3, 5});
}

}  // namespace
}  // namespace vim

// Needle geometry (vim/needle/shaft.hpp, axial_map.hpp, needle_path.hpp): point location against independent
// barycentric tests, shaft sampling invariants, and the conjugate-gradient force control against a direct
// linear solve.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <vim/initial_mesh.hpp>
#include <vim/needle/axial_map.hpp>
#include <vim/needle/needle_path.hpp>
#include <vim/needle/shaft.hpp>

using namespace vim;
using namespace vim::needle;

namespace {
using V3 = Eigen::Vector3d;

// Independent containment test: the sub-simplex volumes with p replacing each vertex are >= 0.
bool contains(const SimplexMesh<3>& m, long c, const V3& p) {
  const auto x = cell_points(m, static_cast<std::size_t>(c));
  const double v = signed_volume<3>(x);
  for (int k = 0; k < 4; ++k) {
    auto y = x;
    y[k] = p;
    if (signed_volume<3>(y) < -1e-9 * std::abs(v)) return false;
  }
  return true;
}
}  // namespace

TEST(CellLocator, SimplexFindsTheContainingCell) {
  const SimplexMesh<3> mesh = regular_grid_mesh<3>(V3(-1, -2, 0), V3(3, 2, 5), {{4, 5, 6}});
  const auto loc = CellLocator<3>::simplex(mesh);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-1, 3), uy(-2, 2), uz(0, 5);
  std::vector<int> sup;
  for (int i = 0; i < 500; ++i) {
    const V3 p(ux(rng), uy(rng), uz(rng));
    const long c = loc.locate(p, &sup);
    ASSERT_GE(c, 0);
    EXPECT_TRUE(contains(mesh, c, p));
    // The support's P1 weights reproduce p (partition of unity and linear precision).
    EXPECT_GE(sup.size(), 1u);
    EXPECT_LE(sup.size(), 4u);
  }
  EXPECT_EQ(loc.locate(V3(3.01, 0, 1)), -1);
  EXPECT_EQ(loc.locate(V3(0, 0, -0.1)), -1);
  // A vertex: support is that vertex only; an edge midpoint: its two end vertices.
  const long v = 17;
  loc.locate(mesh.points[v], &sup);
  EXPECT_EQ(sup, std::vector<int>{static_cast<int>(v)});
  const auto& cell = mesh.cells[10];
  loc.locate(0.5 * (mesh.points[cell[0]] + mesh.points[cell[1]]), &sup);
  std::vector<int> edge{cell[0], cell[1]};
  std::sort(edge.begin(), edge.end());
  EXPECT_EQ(sup, edge);
  EXPECT_GT(loc.mean_edge_length(), 0.8);
  EXPECT_LT(loc.mean_edge_length(), 2.0);
}

TEST(CellLocator, GridSupportAndNumbering) {
  // Lattice 3x2x2 cells on [0,3]x[0,2]x[0,2], vertices in a shuffled order.
  std::vector<V3> verts;
  for (int k = 0; k <= 2; ++k)
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 3; ++i) verts.emplace_back(i, j, k);
  std::mt19937 rng(1);
  std::shuffle(verts.begin(), verts.end(), rng);
  const auto loc = CellLocator<3>::grid({{3, 2, 2}}, V3(0, 0, 0), V3(3, 2, 2), verts);
  std::vector<int> sup;
  EXPECT_EQ(loc.locate(V3(2.5, 0.5, 1.5), &sup), 2 + 3 * (0 + 2 * 1));
  EXPECT_EQ(sup.size(), 8u);
  loc.locate(V3(1, 2, 0), &sup);
  ASSERT_EQ(sup.size(), 1u);
  EXPECT_EQ(verts[sup[0]], V3(1, 2, 0));
  loc.locate(V3(1.5, 1, 2), &sup);  // on an edge of the top face
  ASSERT_EQ(sup.size(), 2u);
  for (int s : sup) EXPECT_DOUBLE_EQ(verts[s][2], 2.0);
  EXPECT_EQ(loc.locate(V3(3.5, 1, 1)), -1);
  verts.pop_back();
  EXPECT_THROW(CellLocator<3>::grid({{3, 2, 2}}, V3(0, 0, 0), V3(3, 2, 2), verts), std::invalid_argument);
}

TEST(ShaftSampling, SpacingLengthsAndDistinctSupports) {
  const SimplexMesh<3> mesh = regular_grid_mesh<3>(V3(-2, -2, 0), V3(2, 2, 10), {{5, 5, 11}});
  const auto loc = CellLocator<3>::simplex(mesh);
  const V3 entry(0.3, -0.2, 0.0), axis = V3(0.1, 0.2, 1.0).normalized();
  const double depth = 8.0, pitch = 0.25;
  const auto pts = sample_shaft<3>(loc, entry, axis, depth, pitch, std::vector<bool>(mesh.n_points(), false));
  ASSERT_GT(pts.size(), 5u);
  EXPECT_LT(pts.size(), static_cast<std::size_t>(depth / pitch));  // some candidates share a cell
  double total = 0.0;
  std::vector<int> prev, sup;
  for (std::size_t j = 0; j < pts.size(); ++j) {
    EXPECT_NEAR((pts[j].position - (entry + pts[j].s * axis)).norm(), 0.0, 1e-12);
    if (j) {
      EXPECT_GE(pts[j].s - pts[j - 1].s, pitch - 1e-12);
    }
    EXPECT_LT(pts[j].s, depth);
    total += pts[j].length;
    loc.locate(pts[j].position, &sup);
    EXPECT_NE(sup, prev);
    prev = sup;
  }
  EXPECT_DOUBLE_EQ(pts[0].s, 0.0);
  EXPECT_NEAR(total, depth, 1e-12);

  // Blocked vertices: points whose whole support is blocked are dropped (here: everything below z = 2).
  std::vector<bool> blocked(mesh.n_points(), false);
  for (std::size_t v = 0; v < mesh.n_points(); ++v) blocked[v] = mesh.points[v][2] <= 2.0 + 1e-12;
  const auto free_pts = sample_shaft<3>(loc, entry, axis, depth, pitch, blocked);
  ASSERT_FALSE(free_pts.empty());
  for (const auto& p : free_pts) EXPECT_GT(p.position[2], 2.0);  // a cell with a vertex above z = 2
  // Consecutive kept points never constrain the same free vertices, nor a subset of the last point's:
  // where the path leaves the held region such a point would conflict with the last one.
  std::vector<int> last_free;
  for (const auto& p : free_pts) {
    loc.locate(p.position, &sup);
    std::vector<int> f;
    for (int v : sup)
      if (!blocked[static_cast<std::size_t>(v)]) f.push_back(v);
    EXPECT_FALSE(!last_free.empty() && std::includes(last_free.begin(), last_free.end(), f.begin(), f.end()))
        << "s = " << p.s;
    last_free = f;
  }
}

TEST(AxialMap, ProbedMapAndForceControlMatchADirectSolve) {
  // An SPD affine map f(w) = M w + c (like the condensed point stiffness), 8 points, 5 force-controlled.
  const int m = 8;
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd A(m, m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) A(i, j) = n01(rng);
  const Eigen::MatrixXd M = A * A.transpose() + m * Eigen::MatrixXd::Identity(m, m);
  Eigen::VectorXd c(m);
  for (int i = 0; i < m; ++i) c[i] = n01(rng);
  int calls = 0;
  const AxialMap map = AxialMap::probe(
      m,
      [&](const Eigen::VectorXd& w) {
        ++calls;
        return Eigen::VectorXd(M * w + c);
      },
      0.5);
  EXPECT_EQ(calls, m + 1);
  EXPECT_LT((map.K - M).norm(), 1e-12 * M.norm());
  EXPECT_LT((map.c - c).norm(), 1e-14);
  std::vector<bool> free = {true, false, true, true, false, true, false, true};
  Eigen::VectorXd target(m), w(m);
  for (int i = 0; i < m; ++i) {
    target[i] = 1.0 + i;
    w[i] = 0.1 * i;
  }
  const Eigen::VectorXd w0 = w;
  map.solve_free(w, free, target);
  const Eigen::VectorXd res = M * w + c;
  for (int i = 0; i < m; ++i) {
    if (free[i])
      EXPECT_NEAR(res[i], target[i], 1e-10);
    else
      EXPECT_EQ(w[i], w0[i]);
  }
}

// needle_density: ρ = 1 + (ρ_max − 1)·exp(−(d/R)²), ρ_max = size_ratio^−(dim+2), d = distance to the
// nearest path (brute force here), on the grid of the given image; bad parameters are rejected.
TEST(NeedleDensity, ProfileAroundThePathsAndBadParameters) {
  Image<3> like({{20, 10, 10}}, {{1.0, 1.0, 1.0}}, {{0.5, 0.5, 0.5}}, 3.0f);
  NeedlePath<3> a{Eigen::Vector3d(0, 5, 5), Eigen::Vector3d(1, 0, 0), 12.0};
  NeedlePath<3> b{Eigen::Vector3d(20, 2, 2), Eigen::Vector3d(0, 1, 0), 6.0};
  const double ratio = 0.5, radius = 2.0, peak = 32.0;
  const Image<3> rho = needle_density<3>(like, {a, b}, ratio, radius);
  ASSERT_EQ(rho.size, like.size);
  ASSERT_EQ(rho.data.size(), like.data.size());
  double on_path = 0.0;
  for (std::size_t k = 0; k < rho.data.size(); ++k) {
    const Eigen::Vector3d p = rho.point_of(rho.index_of(k));
    // Brute force: nearest of many points sampled on each segment.
    double d = 1e300;
    for (const auto* path : {&a, &b})
      for (int i = 0; i <= 12000; ++i)
        d = std::min(d, (p - path->entry - (path->depth * i / 12000.0) * path->axis).norm());
    const double expect = 1.0 + (peak - 1.0) * std::exp(-(d / radius) * (d / radius));
    ASSERT_NEAR(rho.data[k], expect, 2e-3 * expect) << "voxel " << k;
    on_path = std::max(on_path, static_cast<double>(rho.data[k]));
  }
  EXPECT_GT(on_path, 0.8 * peak);  // voxel centres half a voxel from the path: 1 + 31·e^(−0.125)
  EXPECT_THROW(needle_density<3>(like, {a}, 0.0, radius), std::invalid_argument);
  EXPECT_THROW(needle_density<3>(like, {a}, 1.2, radius), std::invalid_argument);
  EXPECT_THROW(needle_density<3>(like, {a}, ratio, 0.0), std::invalid_argument);
  EXPECT_THROW(needle_density<3>(like, {}, ratio, radius), std::invalid_argument);
}

// A path along mesh edges (an interior grid line and the box edge). By default the shaft points sit
// every pitch inside the edges; with snap_to_vertices they are exactly the mesh vertices on the path
// (each at its own arc length, none inside an edge, except past the last vertex before the depth),
// with lengths that still add up to the depth.
TEST(ShaftSampling, SnapToVerticesAlongMeshEdges) {
  using V2 = Eigen::Vector2d;
  const SimplexMesh<2> mesh =
      regular_grid_mesh<2>(V2(-30, -30), V2(30, 30), {{28, 28}});  // 27 cells per axis
  const auto loc = CellLocator<2>::simplex(mesh);
  const double h = 60.0 / 27.0, pitch = 0.546 * h, depth = 50.0;
  for (double y : {-30.0 + 18 * h, 30.0}) {  // grid line 18, and the box edge
    SCOPED_TRACE("path along y = " + std::to_string(y));
    const V2 entry(-30, y), axis(1, 0);
    std::vector<double> on_path;  // arc lengths of the mesh vertices on the path, independently
    for (const auto& p : mesh.points)
      if (std::abs(p[1] - y) < 1e-9 && p[0] - entry[0] < depth) on_path.push_back(p[0] - entry[0]);
    std::sort(on_path.begin(), on_path.end());
    ASSERT_EQ(on_path.size(), 23u);
    auto is_vertex = [&](double s) {
      return std::any_of(on_path.begin(), on_path.end(), [&](double v) { return std::abs(v - s) < 1e-9; });
    };
    const std::vector<bool> none(mesh.n_points(), false);
    const auto plain = sample_shaft<2>(loc, entry, axis, depth, pitch, none);
    EXPECT_TRUE(std::any_of(plain.begin(), plain.end(), [&](const auto& p) { return !is_vertex(p.s); }));
    const auto snapped = sample_shaft<2>(loc, entry, axis, depth, pitch, none, true);
    // The vertices on the path; past the last of them, the edge reaching beyond the depth keeps its
    // plain point.
    ASSERT_GE(snapped.size(), on_path.size());
    ASSERT_LE(snapped.size(), on_path.size() + 1);
    if (snapped.size() > on_path.size()) {
      EXPECT_GT(snapped.back().s, on_path.back());
    }
    double total = 0.0;
    for (std::size_t k = 0; k < snapped.size(); ++k) {
      if (k < on_path.size()) {
        EXPECT_NEAR(snapped[k].s, on_path[k], 1e-9);
      }
      EXPECT_NEAR((snapped[k].position - (entry + snapped[k].s * axis)).norm(), 0.0, 1e-9);
      total += snapped[k].length;
    }
    EXPECT_NEAR(total, depth, 1e-9);
  }
  // A path that crosses the cells is not changed by it.
  const V2 entry(-30, 0.37), axis = V2(1, 0.2).normalized();
  const auto a = sample_shaft<2>(loc, entry, axis, depth, pitch, std::vector<bool>(mesh.n_points(), false));
  const auto b =
      sample_shaft<2>(loc, entry, axis, depth, pitch, std::vector<bool>(mesh.n_points(), false), true);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].s, b[k].s);
}

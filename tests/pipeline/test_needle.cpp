// Needle geometry (needle.hpp): point location against independent barycentric tests, shaft
// sampling invariants, and the conjugate-gradient force control against a direct linear solve.
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/needle.hpp>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

using namespace vim;
using namespace vim::pipeline;

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
}

TEST(ForceControl, ConjugateGradientMatchesDirectSolve) {
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
  auto f = [&](const std::vector<double>& w) {
    ++calls;
    const Eigen::VectorXd r = M * Eigen::Map<const Eigen::VectorXd>(w.data(), m) + c;
    return std::vector<double>(r.data(), r.data() + m);
  };
  std::vector<bool> free = {true, false, true, true, false, true, false, true};
  std::vector<double> target(m, 0.0), w(m, 0.0);
  for (int i = 0; i < m; ++i) {
    target[i] = 1.0 + i;
    w[i] = 0.1 * i;
  }
  const std::vector<double> w0 = w;
  const int solves = solve_axial_forces(w, free, target, f, 1.0, 1e-12, 100);
  EXPECT_EQ(solves, calls);
  EXPECT_LE(solves, 1 + 5 + 2);  // CG on 5 unknowns: at most 5 iterations (+ round-off)
  const std::vector<double> res = f(w);
  for (int i = 0; i < m; ++i) {
    if (free[i])
      EXPECT_NEAR(res[i], target[i], 1e-9);
    else
      EXPECT_EQ(w[i], w0[i]);
  }
  // Independent check: the direct solve of the free block.
  std::vector<int> F;
  for (int i = 0; i < m; ++i)
    if (free[i]) F.push_back(i);
  Eigen::MatrixXd Mff(F.size(), F.size());
  Eigen::VectorXd rhs(F.size());
  for (std::size_t a = 0; a < F.size(); ++a) {
    rhs[a] = target[F[a]] - c[F[a]];
    for (int j = 0; j < m; ++j)
      if (!free[j]) rhs[a] -= M(F[a], j) * w0[j];
    for (std::size_t b = 0; b < F.size(); ++b) Mff(a, b) = M(F[a], F[b]);
  }
  const Eigen::VectorXd x = Mff.ldlt().solve(rhs);
  for (std::size_t a = 0; a < F.size(); ++a) EXPECT_NEAR(w[F[a]], x[a], 1e-9);
}

// Mesh invariants (invariants.hpp, VimOptions::check_invariants): the checker finds each kind of
// violation in hand-broken meshes, and VIM keeps every invariant after every node sweep, swap pass
// and insertion on randomised images (random size, anisotropic spacing, origin, blobs and noise,
// λ, quality bounds, insertion), in 2D and 3D.
#include <vim/initial_mesh.hpp>
#include <vim/invariants.hpp>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>

namespace vim {
namespace {

template <int dim>
struct Box {
  Eigen::Matrix<double, dim, 1> lo, hi;
};

template <int dim>
std::vector<std::uint8_t> face_axes(const SimplexMesh<dim>& mesh, const Box<dim>& box, double tol) {
  std::vector<std::uint8_t> fixed(mesh.n_points(), 0);
  for (std::size_t i = 0; i < mesh.n_points(); ++i)
    for (int a = 0; a < dim; ++a)
      if (std::abs(mesh.points[i][a] - box.lo[a]) <= tol || std::abs(mesh.points[i][a] - box.hi[a]) <= tol)
        fixed[i] |= static_cast<std::uint8_t>(1u << a);
  return fixed;
}

template <int dim>
std::string violation(const SimplexMesh<dim>& mesh, const Box<dim>& box, const std::vector<std::uint8_t>& fixed,
                      const std::vector<char>& alive = {}, QualityBound bound = {}) {
  return mesh_invariant_violation<dim>(mesh, alive, fixed, box.lo, box.hi, 1e-9, bound);
}

// Interior node of a 5×5 (2D) grid on [0,4]^2: node (2,2).
TEST(Invariants, CheckerAcceptsAValidGridAndFindsEachViolation2D) {
  const Box<2> box{Eigen::Vector2d(0, 0), Eigen::Vector2d(4, 4)};
  const SimplexMesh<2> grid = regular_grid_mesh<2>(box.lo, box.hi, {5, 5});
  const auto fixed = face_axes(grid, box, 1e-9);
  EXPECT_EQ(violation(grid, box, fixed), "");

  {  // an edge node leaves its face (stays inside the box)
    auto m = grid;
    m.points[2][1] = 0.3;  // node (2,0) on the face y = 0
    EXPECT_NE(violation(m, box, fixed).find("left its box face"), std::string::npos) << violation(m, box, fixed);
  }
  {  // a node outside the box
    auto m = grid;
    m.points[0] = Eigen::Vector2d(-0.5, 0.0);
    EXPECT_NE(violation(m, box, fixed).find("outside the box"), std::string::npos);
  }
  {  // an inverted cell (two vertices swapped)
    auto m = grid;
    std::swap(m.cells[3][0], m.cells[3][1]);
    EXPECT_NE(violation(m, box, fixed).find("cell 3 is inverted"), std::string::npos) << violation(m, box, fixed);
  }
  {  // a node moved so that a cell gets an interior angle above the bound while staying positive
    // Move the centre node 95% of the way to the midpoint of the opposite edge of one of its cells
    // (its 1-ring is convex, so no cell inverts, but that cell's angle at the node opens to ~170°).
    auto m = grid;
    const int centre = 2 + 5 * 2;
    for (const auto& cell : m.cells) {
      const auto it = std::find(cell.begin(), cell.end(), centre);
      if (it == cell.end()) continue;
      const int k = static_cast<int>(it - cell.begin());
      const Eigen::Vector2d mid = 0.5 * (grid.points[cell[(k + 1) % 3]] + grid.points[cell[(k + 2) % 3]]);
      m.points[centre] = 0.05 * grid.points[centre] + 0.95 * mid;
      break;
    }
    double worst = 0.0;
    bool inverted = false;
    for (std::size_t c = 0; c < m.n_cells(); ++c) {
      worst = std::max(worst, max_dihedral_deg<2>(cell_points(m, c)));
      inverted = inverted || signed_volume(m, c) <= 0.0;
    }
    ASSERT_FALSE(inverted);
    ASSERT_GT(worst, 150.0);  // independent check that the move really breaks the 150° bound
    EXPECT_NE(violation(m, box, fixed).find("quality bound"), std::string::npos) << violation(m, box, fixed);
    QualityBound loose;
    loose.max_dihedral_deg = worst + 1.0;
    EXPECT_EQ(violation(m, box, fixed, {}, loose), "");
  }
  {  // a dead cell leaves a hole
    std::vector<char> alive(grid.n_cells(), 1);
    alive[grid.n_cells() / 2] = 0;
    EXPECT_NE(violation(grid, box, fixed, alive).find("hole"), std::string::npos) << violation(grid, box, fixed, alive);
  }
  {  // a duplicated cell overlaps
    auto m = grid;
    m.cells.push_back(m.cells[7]);
    EXPECT_NE(violation(m, box, fixed).find("more than two cells"), std::string::npos) << violation(m, box, fixed);
  }
  {  // a repeated vertex
    auto m = grid;
    m.cells[0][2] = m.cells[0][1];
    EXPECT_NE(violation(m, box, fixed).find("repeats a vertex"), std::string::npos);
  }
  {  // the minimum-angle and radius-ratio bounds, when enabled
    QualityBound b;
    b.min_dihedral_deg = 50.0;  // the grid's right triangles have 45° angles
    EXPECT_NE(violation(grid, box, fixed, {}, b).find("min angle"), std::string::npos);
    QualityBound r;
    r.min_radius_ratio = 0.9;  // right isosceles triangle: 2·r/R = 2(√2−1) ≈ 0.83
    EXPECT_NE(violation(grid, box, fixed, {}, r).find("radius ratio"), std::string::npos);
  }
}

TEST(Invariants, CheckerFindsAReplacedCell3D) {
  const Box<3> box{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1)};
  const SimplexMesh<3> grid = regular_grid_mesh<3>(box.lo, box.hi, {3, 2, 2});
  const auto fixed = face_axes(grid, box, 1e-9);
  EXPECT_EQ(violation(grid, box, fixed), "");
  // Cell 0 replaced by a copy of cell 5: overlap (facet counts, volume) and a hole where cell 0 was.
  auto m = grid;
  m.cells[0] = m.cells[5];
  const std::string v = violation(m, box, fixed);
  EXPECT_FALSE(v.empty());
}

// VimOptions::check_invariants is wired into optimize(): an initial mesh that breaks the quality
// bound (a valid, positive mesh otherwise) is reported at set-up when checking, accepted when not.
TEST(Invariants, OptimizeChecksWhenAskedAndNamesTheStage) {
  Image<2> img({16, 16}, {0.25, 0.25}, {0.125, 0.125}, 1.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if (img.point_of(img.index_of(k))[0] > 2.0) img.data[k] = 3.0f;
  SimplexMesh<2> initial = regular_grid_mesh<2>(img.box_min(), img.box_max(), {5, 5});
  initial.points[2 + 5 * 2] += Eigen::Vector2d(0.3, 0.2);  // opens some angles well above 95°
  double worst = 0.0;
  for (std::size_t c = 0; c < initial.n_cells(); ++c) {
    ASSERT_GT(signed_volume(initial, c), 0.0);
    worst = std::max(worst, max_dihedral_deg<2>(cell_points(initial, c)));
  }
  ASSERT_GT(worst, 100.0);
  VimOptions o;
  o.max_dihedral_deg = 95.0;
  o.max_iterations = 2;
  o.check_invariants = true;
  try {
    optimize<2>(img, initial, o);
    ADD_FAILURE() << "no InvariantViolation";
  } catch (const InvariantViolation& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("after the set-up of iteration 0"), std::string::npos) << what;
    EXPECT_NE(what.find("quality bound"), std::string::npos) << what;
  }
  o.check_invariants = false;
  EXPECT_NO_THROW(optimize<2>(img, initial, o));
}

// Random image: blobs of random value and radius on a background, plus uniform noise.
template <int dim>
Image<dim> random_image(std::mt19937_64& rng) {
  std::uniform_int_distribution<long> size_d(dim == 2 ? 24 : 10, dim == 2 ? 56 : 18);
  std::uniform_real_distribution<double> spacing_d(0.3, 1.7), origin_d(-20.0, 20.0), u(0.0, 1.0);
  std::array<long, dim> size;
  std::array<double, dim> spacing, origin;
  for (int a = 0; a < dim; ++a) {
    size[a] = size_d(rng);
    spacing[a] = spacing_d(rng);
    origin[a] = origin_d(rng);
  }
  Image<dim> img(size, spacing, origin, static_cast<float>(1.0 + 9.0 * u(rng)));
  const Eigen::Matrix<double, dim, 1> lo = img.box_min(), hi = img.box_max();
  const int blobs = 1 + static_cast<int>(4 * u(rng));
  std::vector<std::pair<Eigen::Matrix<double, dim, 1>, double>> centres;
  std::vector<float> values;
  for (int b = 0; b < blobs; ++b) {
    Eigen::Matrix<double, dim, 1> c;
    for (int a = 0; a < dim; ++a) c[a] = lo[a] + u(rng) * (hi[a] - lo[a]);
    centres.push_back({c, (0.1 + 0.3 * u(rng)) * (hi - lo).minCoeff()});
    values.push_back(static_cast<float>(20.0 * u(rng)));
  }
  const double noise = 0.5 * u(rng);
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto p = img.point_of(img.index_of(k));
    for (int b = 0; b < blobs; ++b)
      if ((p - centres[b].first).norm() <= centres[b].second) img.data[k] = values[b];
    img.data[k] += static_cast<float>(noise * u(rng));
  }
  return img;
}

template <int dim>
void run_random_cases(int cases, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < cases; ++k) {
    const Image<dim> img = random_image<dim>(rng);
    VimOptions o;
    o.check_invariants = true;
    o.lambda = 0.1 + 0.85 * u(rng);
    o.max_dihedral_deg = 140.0 + 25.0 * u(rng);
    if (u(rng) < 0.3) o.min_dihedral_deg = 5.0 + 10.0 * u(rng);
    if (u(rng) < 0.5) o.strategy = VimOptions::NodeStrategy::random_walk;
    o.max_iterations = 4;
    o.seed = rng();
    std::array<int, dim> nodes;
    for (int a = 0; a < dim; ++a) nodes[a] = 3 + static_cast<int>((dim == 2 ? 6 : 3) * u(rng));
    const SimplexMesh<dim> initial = regular_grid_mesh<dim>(img.box_min(), img.box_max(), nodes);
    if (u(rng) < 0.5) {
      o.insert_nodes = static_cast<int>(initial.n_points() / 3);
      o.node_budget = static_cast<long>(initial.n_points()) + o.insert_nodes;
    }
    SCOPED_TRACE("case " + std::to_string(k) + ": λ " + std::to_string(o.lambda) + ", bound " +
                 std::to_string(o.max_dihedral_deg) + "°, min " + std::to_string(o.min_dihedral_deg) + "°, insert " +
                 std::to_string(o.insert_nodes));
    VimResult<dim> r;
    ASSERT_NO_THROW(r = optimize<dim>(img, initial, o)) << "a VIM stage broke a mesh invariant";
    ASSERT_GE(r.history.size(), 2u);
    // Re-check of the final (compacted, re-oriented) mesh that optimize() returns.
    const Box<dim> box{img.box_min(), img.box_max()};
    const double tol = 1e-9 * (box.hi - box.lo).norm();
    QualityBound b;
    b.max_dihedral_deg = o.max_dihedral_deg;
    b.min_dihedral_deg = o.min_dihedral_deg;
    EXPECT_EQ(mesh_invariant_violation<dim>(r.mesh, {}, {}, box.lo, box.hi, tol, b, 1e-6), "");
    for (std::size_t i = 1; i < r.history.size(); ++i) EXPECT_LE(r.history[i].energy, r.history[i - 1].energy);
  }
}

TEST(Invariants, HoldAfterEveryStageOnRandomImages2D) { run_random_cases<2>(16, 20261123); }
TEST(Invariants, HoldAfterEveryStageOnRandomImages3D) { run_random_cases<3>(6, 7); }

}  // namespace
}  // namespace vim

// Tests of the incremental adjacency behind the swaps of paper §IV-B: vertex→cells and
// facet→cells agree with brute-force recomputation on Kuhn meshes, after random removal/re-adding
// of cells, and consistent() detects a corrupted structure.
#include <vim/adjacency.hpp>
#include <vim/initial_mesh.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

namespace vim {
namespace {

template <int dim>
SimplexMesh<dim> unit_grid(int n) {
  std::array<int, dim> nodes;
  nodes.fill(n);
  return regular_grid_mesh<dim>(Eigen::Matrix<double, dim, 1>::Zero(), Eigen::Matrix<double, dim, 1>::Ones(), nodes);
}

// Neighbours found by brute force: cells sharing dim vertices with c.
template <int dim>
int brute_neighbor(const SimplexMesh<dim>& mesh, int c, int k) {
  std::set<int> face;
  for (int j = 0; j <= dim; ++j)
    if (j != k) face.insert(mesh.cells[c][j]);
  for (std::size_t d = 0; d < mesh.n_cells(); ++d) {
    if (static_cast<int>(d) == c) continue;
    int shared = 0;
    for (int v : mesh.cells[d]) shared += static_cast<int>(face.count(v));
    if (shared == dim) return static_cast<int>(d);
  }
  return -1;
}

template <int dim>
void check_against_brute_force(int n) {
  const auto mesh = unit_grid<dim>(n);
  Adjacency<dim> adj;
  adj.build(mesh.n_points(), mesh.cells);
  long boundary = 0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    for (int k = 0; k <= dim; ++k) {
      const int nb = adj.neighbor(static_cast<int>(c), mesh.cells[c], k);
      EXPECT_EQ(nb, brute_neighbor(mesh, static_cast<int>(c), k));
      if (nb < 0) ++boundary;
    }
  // Boundary facets of a Kuhn grid: 2 per square face cell in 3D, 1 per boundary segment in 2D.
  const long per_face = dim == 3 ? 2L * (n - 1) * (n - 1) : static_cast<long>(n - 1);
  EXPECT_EQ(boundary, 2L * dim * per_face);
  for (std::size_t v = 0; v < mesh.n_points(); ++v) {
    std::vector<int> expect;
    for (std::size_t c = 0; c < mesh.n_cells(); ++c)
      if (std::count(mesh.cells[c].begin(), mesh.cells[c].end(), static_cast<int>(v))) expect.push_back(static_cast<int>(c));
    EXPECT_EQ(adj.cells_of(static_cast<int>(v)), expect);
  }
  std::vector<int> ring;
  adj.cells_with_edge(mesh.cells[0][0], mesh.cells[0][1], ring);
  EXPECT_TRUE(std::find(ring.begin(), ring.end(), 0) != ring.end());
  EXPECT_TRUE(adj.consistent(mesh.n_points(), mesh.cells));
}

TEST(Adjacency, MatchesBruteForce2D) { check_against_brute_force<2>(5); }
TEST(Adjacency, MatchesBruteForce3D) { check_against_brute_force<3>(4); }

template <int dim>
void check_incremental() {
  auto mesh = unit_grid<dim>(4);
  Adjacency<dim> adj;
  adj.build(mesh.n_points(), mesh.cells);
  std::vector<char> alive(mesh.n_cells(), 1);
  std::mt19937 rng(7);
  for (int step = 0; step < 200; ++step) {
    const int c = static_cast<int>(rng() % mesh.n_cells());
    if (alive[c])
      adj.remove_cell(c, mesh.cells[c]);
    else
      adj.add_cell(c, mesh.cells[c]);
    alive[c] = !alive[c];
    if (step % 20 == 0) {
      ASSERT_TRUE(adj.consistent(mesh.n_points(), mesh.cells, alive)) << "step " << step;
    }
  }
  EXPECT_TRUE(adj.consistent(mesh.n_points(), mesh.cells, alive));
  // The check can fail: drop a live cell from the structure only.
  const int c = static_cast<int>(std::find(alive.begin(), alive.end(), 1) - alive.begin());
  adj.remove_cell(c, mesh.cells[c]);
  EXPECT_FALSE(adj.consistent(mesh.n_points(), mesh.cells, alive));
}

TEST(Adjacency, IncrementalUpdatesStayConsistent2D) { check_incremental<2>(); }
TEST(Adjacency, IncrementalUpdatesStayConsistent3D) { check_incremental<3>(); }

TEST(Adjacency, RejectsNonManifoldFacet) {
  SimplexMesh<2> m;
  m.points = {{0, 0}, {1, 0}, {0, 1}, {0, -1}, {-1, 0}};
  m.cells = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};  // edge (0,1) in three triangles
  Adjacency<2> adj;
  EXPECT_THROW(adj.build(m.n_points(), m.cells), std::invalid_argument);
}

}  // namespace
}  // namespace vim

// Tests of vim::match_facets, the facet matching behind the swap adjacency, the segmentation and the
// mesh invariants. Truth: brute force over every pair of selected cells (two cells share a facet iff
// they share dim vertices), on Kuhn meshes with cells deselected at random and with a facet made
// non-manifold by a duplicated cell.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>
#include <vim/facets.hpp>
#include <vim/initial_mesh.hpp>

namespace vim {
namespace {

template <int dim>
std::vector<std::array<int, dim + 1>> kuhn_cells(int n) {
  std::array<int, dim> nodes;
  nodes.fill(n);
  return regular_grid_mesh<dim>(Eigen::Matrix<double, dim, 1>::Zero(), Eigen::Matrix<double, dim, 1>::Ones(),
                                nodes)
      .cells;
}

// Brute force: for each facet (as a vertex set) of a selected cell, the selected cells holding it,
// ascending.
template <int dim>
std::map<std::set<int>, std::vector<std::size_t>> brute_force(
    const std::vector<std::array<int, dim + 1>>& cells, const std::vector<char>& selected) {
  std::map<std::set<int>, std::vector<std::size_t>> holders;
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (!selected[c]) continue;
    for (int k = 0; k <= dim; ++k) {
      std::set<int> facet;
      for (int i = 0; i <= dim; ++i)
        if (i != k) facet.insert(cells[c][i]);
      if (holders.count(facet)) continue;
      for (std::size_t d = 0; d < cells.size(); ++d) {
        if (!selected[d]) continue;
        int shared = 0;
        for (int v : cells[d]) shared += static_cast<int>(facet.count(v));
        if (shared == dim) holders[facet].push_back(d);
      }
    }
  }
  return holders;
}

template <int dim>
void check(const std::vector<std::array<int, dim + 1>>& cells, std::size_t n_points,
           const std::vector<char>& selected) {
  const FacetIncidence<dim> got = match_facets<dim>(n_points, cells, selected);
  const auto want = brute_force<dim>(cells, selected);
  ASSERT_EQ(got.n_facets(), want.size());
  ASSERT_EQ(got.start.back(), got.uses.size());
  for (std::size_t g = 0; g < got.n_facets(); ++g) {
    const auto& first = got.use(g, 0).vertices;
    ASSERT_TRUE(std::is_sorted(first.begin(), first.end()));
    const std::set<int> key(first.begin(), first.end());
    ASSERT_TRUE(want.count(key)) << "facet group " << g;
    std::vector<std::size_t> holders;
    for (std::size_t i = 0; i < got.count(g); ++i) {
      const auto& u = got.use(g, i);
      ASSERT_EQ(u.vertices, first);
      ASSERT_EQ(sorted_facet<dim>(cells[u.cell()], u.local()), first);  // the use's cell and local vertex
      holders.push_back(u.cell());
    }
    EXPECT_EQ(holders, want.at(key)) << "facet group " << g;  // every holder, in cell order
    if (g > 0) {
      EXPECT_LT(got.use(g - 1, 0).vertices, first);  // facets in lexicographic order
    }
  }
}

TEST(Facets, MatchBruteForceOnKuhnMeshesWithCellsLeftOut) {
  std::mt19937 rng(7);
  for (int n : {2, 3, 4}) {
    const auto cells2 = kuhn_cells<2>(n + 1);
    const auto cells3 = kuhn_cells<3>(n);
    for (double keep : {1.0, 0.7, 0.3}) {
      std::bernoulli_distribution pick(keep);
      std::vector<char> sel2(cells2.size()), sel3(cells3.size());
      for (auto& s : sel2) s = pick(rng);
      for (auto& s : sel3) s = pick(rng);
      check<2>(cells2, static_cast<std::size_t>((n + 1) * (n + 1)), sel2);
      check<3>(cells3, static_cast<std::size_t>(n * n * n), sel3);
    }
  }
}

TEST(Facets, AFacetOfThreeCellsIsOneGroupInCellOrder) {
  auto cells = kuhn_cells<3>(3);
  const std::size_t n = cells.size();
  cells.push_back(cells[5]);  // every facet of cell 5 now has one more holder
  check<3>(cells, 27, std::vector<char>(cells.size(), 1));
  const FacetIncidence<3> got = match_facets<3>(27, cells);
  int three = 0;
  for (std::size_t g = 0; g < got.n_facets(); ++g)
    if (got.count(g) == 3) {
      ++three;
      EXPECT_EQ(got.use(g, 2).cell(), n);  // the copy comes last
    }
  EXPECT_GE(three, 1);
}

TEST(Facets, SortedFacetLeavesOutTheOppositeVertex) {
  EXPECT_EQ((sorted_facet<3>({9, 2, 7, 4}, 0)), (std::array<int, 3>{2, 4, 7}));
  EXPECT_EQ((sorted_facet<3>({9, 2, 7, 4}, 2)), (std::array<int, 3>{2, 4, 9}));
  EXPECT_EQ((sorted_facet<2>({5, 1, 3}, 1)), (std::array<int, 2>{3, 5}));
}

TEST(Facets, AVertexOutsideThePointsIsRejected) {
  const std::vector<std::array<int, 3>> cells = {{0, 1, 2}, {1, 2, 4}};
  EXPECT_THROW(match_facets<2>(4, cells), std::invalid_argument);
  EXPECT_NO_THROW(match_facets<2>(4, cells, {1, 0}));  // a cell left out is not read
}

}  // namespace
}  // namespace vim

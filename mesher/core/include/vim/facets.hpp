// Facet matching of simplex meshes: which cells share a facet (dim vertices). The one
// implementation behind the swap adjacency (paper §IV-B), the face-connected components of the
// segmentation (§VI-B), the conformity check of the mesh invariants and the elasticity model's
// mesh check (docs/architecture.md, "Core").
#pragma once

#include <array>
#include <cstddef>
#include <utility>
#include <vector>

namespace vim {

// The facet of `cell` opposite its local vertex k: the other dim vertex ids, ascending.
template <int dim>
std::array<int, dim> sorted_facet(const std::array<int, dim + 1>& cell, int k) {
  std::array<int, dim> f{};
  for (int i = 0, j = 0; i <= dim; ++i)
    if (i != k) f[j++] = cell[i];
  for (int i = 1; i < dim; ++i)  // insertion sort of 2 or 3 ids
    for (int j = i; j > 0 && f[j] < f[j - 1]; --j) std::swap(f[j], f[j - 1]);
  return f;
}

// Every facet of the selected cells, grouped by vertex set.
template <int dim>
struct FacetIncidence {
  // One cell's use of a facet: the facet's sorted vertex ids and its position cell·(dim+1) + k,
  // k the local vertex opposite the facet.
  struct Use {
    std::array<int, dim> vertices;
    std::size_t position;
    std::size_t cell() const { return position / (dim + 1); }
    int local() const { return static_cast<int>(position % (dim + 1)); }
  };
  // Sorted by (vertices, position): the uses of one facet are adjacent, in cell order, and the
  // facets appear in lexicographic order of their vertex ids.
  std::vector<Use> uses;
  // Facet g is uses[start[g]] .. uses[start[g+1] − 1]; start.back() == uses.size().
  std::vector<std::size_t> start;

  std::size_t n_facets() const { return start.size() - 1; }
  std::size_t count(std::size_t g) const { return start[g + 1] - start[g]; }
  const Use& use(std::size_t g, std::size_t i) const { return uses[start[g] + i]; }
};

// Matches the facets of cells[c] for every c with selected[c] != 0 (selected empty: every cell).
// Linear in the number of cells: a counting sort by the facet's smallest vertex, then a sort of each
// (small) bucket. Vertex ids must lie in [0, n_points); throws std::invalid_argument otherwise.
template <int dim>
FacetIncidence<dim> match_facets(std::size_t n_points, const std::vector<std::array<int, dim + 1>>& cells,
                                 const std::vector<char>& selected = {});

extern template FacetIncidence<2> match_facets<2>(std::size_t, const std::vector<std::array<int, 3>>&,
                                                  const std::vector<char>&);
extern template FacetIncidence<3> match_facets<3>(std::size_t, const std::vector<std::array<int, 4>>&,
                                                  const std::vector<char>&);

}  // namespace vim

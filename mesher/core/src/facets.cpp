// Facet matching (facets.hpp): facets bucketed by their smallest vertex (counting sort), each bucket
// sorted by (vertices, position), so equal facets are adjacent in cell order.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <vim/facets.hpp>

namespace vim {

template <int dim>
FacetIncidence<dim> match_facets(std::size_t n_points, const std::vector<std::array<int, dim + 1>>& cells,
                                 const std::vector<char>& selected) {
  using Use = typename FacetIncidence<dim>::Use;
  auto chosen = [&](std::size_t c) { return selected.empty() || selected[c]; };
  std::vector<std::size_t> bucket(n_points + 1, 0);
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (!chosen(c)) continue;
    for (int v : cells[c])
      if (v < 0 || static_cast<std::size_t>(v) >= n_points)
        throw std::invalid_argument("match_facets: cell " + std::to_string(c) + " refers to vertex " +
                                    std::to_string(v) + ", outside [0, " + std::to_string(n_points) + ")");
    for (int k = 0; k <= dim; ++k) ++bucket[static_cast<std::size_t>(sorted_facet<dim>(cells[c], k)[0]) + 1];
  }
  for (std::size_t v = 0; v < n_points; ++v) bucket[v + 1] += bucket[v];
  FacetIncidence<dim> out;
  out.uses.resize(bucket[n_points]);
  {
    std::vector<std::size_t> next(bucket.begin(), bucket.end() - 1);
    for (std::size_t c = 0; c < cells.size(); ++c) {
      if (!chosen(c)) continue;
      for (int k = 0; k <= dim; ++k) {
        Use u{sorted_facet<dim>(cells[c], k), c * (dim + 1) + static_cast<std::size_t>(k)};
        out.uses[next[static_cast<std::size_t>(u.vertices[0])]++] = u;
      }
    }
  }
  auto less = [](const Use& x, const Use& y) {
    return x.vertices != y.vertices ? x.vertices < y.vertices : x.position < y.position;
  };
  for (std::size_t v = 0; v < n_points; ++v)
    std::sort(out.uses.begin() + static_cast<std::ptrdiff_t>(bucket[v]),
              out.uses.begin() + static_cast<std::ptrdiff_t>(bucket[v + 1]), less);
  out.start.reserve(out.uses.size() / 2 + 2);
  for (std::size_t i = 0; i < out.uses.size(); ++i)
    if (i == 0 || out.uses[i].vertices != out.uses[i - 1].vertices) out.start.push_back(i);
  out.start.push_back(out.uses.size());
  return out;
}

template FacetIncidence<2> match_facets<2>(std::size_t, const std::vector<std::array<int, 3>>&,
                                           const std::vector<char>&);
template FacetIncidence<3> match_facets<3>(std::size_t, const std::vector<std::array<int, 4>>&,
                                           const std::vector<char>&);

}  // namespace vim

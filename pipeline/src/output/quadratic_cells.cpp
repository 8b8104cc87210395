// Mid-edge nodes of quadratic simplex cells (quadratic_cells.hpp).
#include <algorithm>
#include <map>
#include <vim/pipeline/output/quadratic_cells.hpp>

namespace vim::pipeline {

template <int dim>
const std::vector<std::array<int, 2>>& quadratic_edge_order() {
  using E = std::array<int, 2>;
  static const std::vector<E> order =
      dim == 3 ? std::vector<E>{E{{0, 1}}, E{{1, 2}}, E{{2, 0}}, E{{0, 3}}, E{{1, 3}}, E{{2, 3}}}
               : std::vector<E>{E{{0, 1}}, E{{1, 2}}, E{{2, 0}}};
  return order;
}

template <int dim>
QuadraticCells<dim> quadratic_cells(const std::vector<std::array<int, dim + 1>>& cells,
                                    std::size_t n_vertices) {
  QuadraticCells<dim> q;
  std::map<std::pair<int, int>, long> edge_of;
  q.cells.reserve(cells.size());
  for (const auto& c : cells) {
    std::array<long, QuadraticCells<dim>::nodes_per_cell> nodes{};
    for (int k = 0; k <= dim; ++k) nodes[k] = c[k];
    int k = dim + 1;
    for (const auto& [a, b] : quadratic_edge_order<dim>()) {
      const std::pair<int, int> key{std::min(c[a], c[b]), std::max(c[a], c[b])};
      auto [it, added] = edge_of.emplace(key, static_cast<long>(q.edges.size()));
      if (added) q.edges.push_back(std::array<int, 2>{{key.first, key.second}});
      nodes[k++] = static_cast<long>(n_vertices) + it->second;
    }
    q.cells.push_back(nodes);
  }
  return q;
}

template const std::vector<std::array<int, 2>>& quadratic_edge_order<2>();
template const std::vector<std::array<int, 2>>& quadratic_edge_order<3>();
template QuadraticCells<2> quadratic_cells<2>(const std::vector<std::array<int, 3>>&, std::size_t);
template QuadraticCells<3> quadratic_cells<3>(const std::vector<std::array<int, 4>>&, std::size_t);

}  // namespace vim::pipeline

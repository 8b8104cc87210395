// Incremental vertex→cells and facet→cells adjacency used by the swaps of paper §IV-B.
// Built from vim::match_facets; facet keys pack the sorted vertex ids (2D: 2×32 bits, 3D: 3×21 bits).
#include <algorithm>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vim/adjacency.hpp>
#include <vim/facets.hpp>

namespace vim {

template <int dim>
typename Adjacency<dim>::FaceKey Adjacency<dim>::key_of(const std::array<int, dim>& f) {
  if constexpr (dim == 2) {
    return (static_cast<FaceKey>(f[0]) << 32) | static_cast<FaceKey>(f[1]);
  } else {
    return (static_cast<FaceKey>(f[0]) << 42) | (static_cast<FaceKey>(f[1]) << 21) |
           static_cast<FaceKey>(f[2]);
  }
}

template <int dim>
typename Adjacency<dim>::FaceKey Adjacency<dim>::face_key(const Cell& v, int k) {
  return key_of(sorted_facet<dim>(v, k));
}

template <int dim>
void Adjacency<dim>::build(std::size_t n_points, const std::vector<Cell>& cells,
                           const std::vector<char>& alive) {
  if (n_points > max_points())
    throw std::invalid_argument("mesh has " + std::to_string(n_points) +
                                " nodes: the swap adjacency supports at most " +
                                std::to_string(max_points()));
  const FacetIncidence<dim> facets = match_facets<dim>(n_points, cells, alive);
  vertex_cells_.assign(n_points, {});
  for (std::size_t c = 0; c < cells.size(); ++c)
    if (alive.empty() || alive[c])
      for (int v : cells[c]) vertex_cells_[v].push_back(static_cast<int>(c));  // ascending: c grows
  faces_.clear();
  faces_.reserve(cells.size() * (dim + 1) / 2 + 16);
  for (std::size_t g = 0; g < facets.n_facets(); ++g) {
    if (facets.count(g) > 2)
      throw std::invalid_argument("non-manifold mesh: a facet is shared by more than two cells");
    const int first = static_cast<int>(facets.use(g, 0).cell());
    const int second = facets.count(g) == 2 ? static_cast<int>(facets.use(g, 1).cell()) : -1;
    faces_.emplace(key_of(facets.use(g, 0).vertices), std::array<int, 2>{first, second});
  }
}

template <int dim>
void Adjacency<dim>::add_point() {
  if (vertex_cells_.size() >= max_points())
    throw std::length_error("mesh would have " + std::to_string(vertex_cells_.size() + 1) +
                            " nodes: the swap adjacency supports at most " + std::to_string(max_points()) +
                            " (facet keys pack " + (dim == 3 ? "21" : "32") + " bits per node)");
  vertex_cells_.emplace_back();
}

template <int dim>
void Adjacency<dim>::add_cell(int c, const Cell& v) {
  for (int i = 0; i <= dim; ++i) {
    auto& list = vertex_cells_[v[i]];
    list.insert(std::upper_bound(list.begin(), list.end(), c), c);
  }
  for (int k = 0; k <= dim; ++k) {
    auto it = faces_.try_emplace(face_key(v, k), std::array<int, 2>{-1, -1}).first;
    auto& pair = it->second;
    if (pair[0] < 0)
      pair[0] = c;
    else if (pair[1] < 0)
      pair[1] = c;
    else
      throw std::invalid_argument("non-manifold mesh: a facet is shared by more than two cells");
  }
}

template <int dim>
void Adjacency<dim>::remove_cell(int c, const Cell& v) {
  for (int i = 0; i <= dim; ++i) {
    auto& list = vertex_cells_[v[i]];
    auto it = std::lower_bound(list.begin(), list.end(), c);
    if (it != list.end() && *it == c) list.erase(it);
  }
  for (int k = 0; k <= dim; ++k) {
    auto it = faces_.find(face_key(v, k));
    if (it == faces_.end()) continue;
    auto& pair = it->second;
    if (pair[0] == c) {
      pair[0] = pair[1];
      pair[1] = -1;
    } else if (pair[1] == c) {
      pair[1] = -1;
    }
    if (pair[0] < 0) faces_.erase(it);
  }
}

template <int dim>
int Adjacency<dim>::neighbor(int c, const Cell& v, int k) const {
  auto it = faces_.find(face_key(v, k));
  if (it == faces_.end()) return -1;
  return it->second[0] == c ? it->second[1] : it->second[0];
}

template <int dim>
void Adjacency<dim>::cells_with_edge(int a, int b, std::vector<int>& out) const {
  out.clear();
  const auto& la = vertex_cells_[a];
  const auto& lb = vertex_cells_[b];
  std::set_intersection(la.begin(), la.end(), lb.begin(), lb.end(), std::back_inserter(out));
}

template <int dim>
bool Adjacency<dim>::consistent(std::size_t n_points, const std::vector<Cell>& cells,
                                const std::vector<char>& alive) const {
  Adjacency<dim> fresh;
  fresh.build(n_points, cells, alive);
  if (fresh.vertex_cells_ != vertex_cells_ || fresh.faces_.size() != faces_.size()) return false;
  for (const auto& [key, pair] : fresh.faces_) {
    auto it = faces_.find(key);
    if (it == faces_.end()) return false;
    auto x = pair, y = it->second;
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    if (x != y) return false;
  }
  return true;
}

template class Adjacency<2>;
template class Adjacency<3>;

}  // namespace vim

// Incremental mesh adjacency for the connectivity updates of paper §IV-B (GRUMMP-style swaps):
// vertex → incident cells and facet → the one or two cells sharing it, updated cell by cell so a
// swap never rebuilds the structure (docs/architecture.md, "Core").
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

namespace vim {

template <int dim>
class Adjacency {
 public:
  using Cell = std::array<int, dim + 1>;

  // Builds from scratch (facets matched by vim::match_facets); cells with alive[c] == 0 are skipped
  // (alive may be empty = all alive). Throws std::invalid_argument if a facet is shared by more than
  // two cells, a vertex id is outside [0, n_points) or, in 3D, the mesh has more than 2^21 nodes
  // (facet keys pack three 21-bit indices).
  void build(std::size_t n_points, const std::vector<Cell>& cells, const std::vector<char>& alive = {});

  // The largest node count whose facet keys cannot collide (3D: 2^21; 2D: the int node ids).
  static constexpr std::size_t max_points() {
    return dim == 3 ? std::size_t(1) << 21 : std::size_t(std::numeric_limits<int>::max());
  }
  // One more node; throws std::length_error beyond max_points() (keys would collide silently).
  void add_point();
  void pop_point() { vertex_cells_.pop_back(); }  // the last point must have no cells
  void add_cell(int c, const Cell& v);
  void remove_cell(int c, const Cell& v);

  const std::vector<int>& cells_of(int vertex) const { return vertex_cells_[vertex]; }
  std::size_t n_points() const { return vertex_cells_.size(); }

  // The cell other than c sharing the facet of c opposite local vertex k; -1 on the boundary.
  int neighbor(int c, const Cell& v, int k) const;

  // Cells containing both a and b (the edge's ring), in ascending order, written to out.
  void cells_with_edge(int a, int b, std::vector<int>& out) const;

  // True iff this structure equals the one built from scratch from (cells, alive).
  bool consistent(std::size_t n_points, const std::vector<Cell>& cells,
                  const std::vector<char>& alive = {}) const;

 private:
  using FaceKey = std::uint64_t;
  // Key of the facet of v opposite its local vertex k (vim::sorted_facet, packed: 2D 2×32 bits,
  // 3D 3×21 bits).
  static FaceKey face_key(const Cell& v, int k);
  static FaceKey key_of(const std::array<int, dim>& sorted);

  std::vector<std::vector<int>> vertex_cells_;  // kept sorted ascending
  std::unordered_map<FaceKey, std::array<int, 2>> faces_;
};

extern template class Adjacency<2>;
extern template class Adjacency<3>;

}  // namespace vim

// Connectivity updates of paper §IV-B (GRUMMP-style, ref. [37]): 2D edge flips; 3D 2-3, 3-2 and
// 4-4 swaps. A swap is taken iff every new element passes the quality bound, the new elements tile
// exactly the region of the old ones, and E (Eq. 7) drops. Boundary facets are never swapped.
#include <algorithm>
#include <cmath>
#include <vim/energy.hpp>
#include <vim/optimizer.hpp>

namespace vim {

// Replaces old_cells by the alternative with the lowest energy, if that energy is below the old
// one. Each new cell is oriented positively; an alternative whose |volumes| do not sum to the old
// volume (the new cells overlap / leave the region) or with an unacceptable cell is skipped.
template <int dim>
bool VimOptimizer<dim>::try_replace(const int* old_cells, int n_old, const Cell* alternatives, int n_alt,
                                    int n_new) {
  double old_cost = 0.0, old_volume = 0.0;
  for (int i = 0; i < n_old; ++i) {
    old_cost += cache_[old_cells[i]].cost;
    old_volume += cache_[old_cells[i]].volume;
  }
  double best = old_cost * (1.0 - 1e-12);
  int best_alt = -1;
  std::vector<Cell>& cells = swap_cells_;
  std::vector<Cell>& best_cells = swap_best_cells_;
  std::vector<CellCache>& caches = swap_caches_;
  std::vector<CellCache>& best_caches = swap_best_caches_;
  std::vector<Simplex>& simplices = swap_simplices_;
  for (int a = 0; a < n_alt; ++a) {
    cells.assign(alternatives + static_cast<std::ptrdiff_t>(a) * n_new,
                 alternatives + static_cast<std::ptrdiff_t>(a + 1) * n_new);
    // The tests in order of cost (the outcome does not depend on it): the tiling, then the E_G
    // share alone as a lower bound (at or above the best: the voxel sums are not needed), then the
    // quality bound of each new cell, then the voxel sums.
    // Each new cell's points, positively oriented, gathered once for all the tests.
    simplices.clear();
    double volume = 0.0;
    for (Cell& v : cells) {
      Simplex x;
      for (int j = 0; j <= dim; ++j) x[j] = mesh_.points[v[j]];
      double vol = signed_volume<dim>(x);
      if (vol < 0.0) {
        std::swap(v[0], v[1]);
        std::swap(x[0], x[1]);
        vol = -vol;
      }
      volume += vol;
      simplices.push_back(x);
    }
    if (std::abs(volume - old_volume) > 1e-9 * old_volume) continue;
    double geometric = 0.0;
    for (const Simplex& x : simplices)
      geometric +=
          wg_ * geometric_energy<dim>(x) * (density_ ? density_->interpolate(centroid<dim>(x)) : 1.0);
    if (geometric >= best) continue;
    if (!std::all_of(simplices.begin(), simplices.end(), [&](const Simplex& x) { return acceptable(x); }))
      continue;
    caches.clear();
    double total = 0.0;
    for (const Simplex& x : simplices) {
      caches.push_back(evaluate(x));
      total += caches.back().cost;
    }
    if (total < best) {
      best = total;
      best_alt = a;
      std::swap(best_cells, cells);
      std::swap(best_caches, caches);
    }
  }
  if (best_alt < 0) return false;

  std::vector<int>& slots = swap_slots_;
  slots.assign(old_cells, old_cells + n_old);
  std::sort(slots.begin(), slots.end());
  for (int c : slots) {
    for (int w : mesh_.cells[c]) dirty_[w] = 1;
    adj_.remove_cell(c, mesh_.cells[c]);
  }
  while (slots.size() > best_cells.size()) {
    const int c = slots.back();
    slots.pop_back();
    alive_[c] = 0;
    --n_live_;
    free_.push_back(c);
  }
  for (int c : slots) {
    alive_[c] = 0;
    --n_live_;
  }
  while (slots.size() < best_cells.size()) slots.push_back(new_cell_slot());
  for (std::size_t k = 0; k < best_cells.size(); ++k) set_cell(slots[k], best_cells[k], best_caches[k]);
  return true;
}

// The live cell `cell`'s neighbour nb across its facet opposite local vertex k, and nb's vertex off
// that facet; false for a dead cell or a boundary facet.
template <int dim>
static bool across_facet(const Adjacency<dim>& adj, const std::vector<std::array<int, dim + 1>>& cells,
                         const std::vector<char>& alive, int cell, int k, int& nb, int& opposite) {
  if (!alive[cell]) return false;
  const std::array<int, dim + 1>& v = cells[cell];
  nb = adj.neighbor(cell, v, k);
  if (nb < 0) return false;
  for (int w : cells[nb]) {
    bool on_facet = false;
    for (int j = 0; j <= dim; ++j) on_facet = on_facet || (j != k && w == v[j]);
    if (!on_facet) opposite = w;
  }
  return true;
}

// The 2D edge flip and the 3D 2-3 swap: the two cells across the facet opposite local vertex k become
// the cells that join their two vertices off that facet to each vertex (2D) or edge (3D) of the facet.
template <int dim>
bool VimOptimizer<dim>::try_facet_swap(int cell, int k) {
  int nb = -1, e = -1;
  if (!across_facet<dim>(adj_, mesh_.cells, alive_, cell, k, nb, e)) return false;
  const Cell v = mesh_.cells[cell];
  const int old[2] = {cell, nb};
  if constexpr (dim == 2) {
    const int c = v[k], a = v[(k + 1) % 3], b = v[(k + 2) % 3];
    const Cell alt[2] = {Cell{c, a, e}, Cell{c, e, b}};
    return try_replace(old, 2, alt, 1, 2);
  } else {
    std::array<int, 3> f;
    for (int j = 0, m = 0; j < 4; ++j)
      if (j != k) f[m++] = v[j];
    const int d = v[k];
    const Cell alt[3] = {Cell{d, e, f[0], f[1]}, Cell{d, e, f[1], f[2]}, Cell{d, e, f[2], f[0]}};
    return try_replace(old, 2, alt, 1, 3);
  }
}

template <int dim>
bool VimOptimizer<dim>::try_flip(int cell, int k) {
  return dim == 2 && try_facet_swap(cell, k);
}

template <int dim>
bool VimOptimizer<dim>::try_swap_23(int cell, int k) {
  return dim == 3 && try_facet_swap(cell, k);
}

namespace {
// Orders the link of an edge (the opposite edges (u, v) of its m <= 4 ring cells) into a closed
// cycle. Returns false if the link is not a single closed cycle (a boundary edge).
bool link_cycle(const std::array<std::array<int, 2>, 4>& link, std::size_t m, std::vector<int>& cycle) {
  std::array<char, 4> used{};
  cycle.assign(1, link[0][0]);
  int current = link[0][1];
  used[0] = 1;
  for (std::size_t step = 1; step < m; ++step) {
    cycle.push_back(current);
    std::size_t j = 0;
    while (j < m && (used[j] || (link[j][0] != current && link[j][1] != current))) ++j;
    if (j == m) return false;
    used[j] = 1;
    current = link[j][0] == current ? link[j][1] : link[j][0];
  }
  if (current != cycle[0]) return false;
  std::array<int, 4> sorted{};
  std::copy(cycle.begin(), cycle.end(), sorted.begin());
  std::sort(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(m));
  return std::adjacent_find(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(m)) ==
         sorted.begin() + static_cast<std::ptrdiff_t>(m);
}
}  // namespace

// The ring of edge (a, b) and its link as a cycle; false unless it is an interior edge with m <= 4
// cells.
template <int dim>
static bool edge_ring(const Adjacency<dim>& adj, const std::vector<std::array<int, dim + 1>>& cells, int a,
                      int b, std::size_t m, std::vector<int>& ring, std::vector<int>& cycle) {
  adj.cells_with_edge(a, b, ring);
  if (ring.size() != m || m > 4) return false;
  std::array<std::array<int, 2>, 4> link;
  for (std::size_t r = 0; r < m; ++r) {
    std::array<int, 2> uv{-1, -1};
    int j = 0;
    for (int w : cells[ring[r]])
      if (w != a && w != b) uv[j++] = w;
    link[r] = uv;
  }
  return link_cycle(link, m, cycle);
}

// The 3-2 (m = 3) and 4-4 (m = 4) swaps of the interior edge (a, b) in 3D: its m cells become the
// cells that join a and b to each triangle of its link polygon (3-2: the triangle; 4-4: the two
// triangulations of the quadrilateral, tried in turn).
template <int dim>
bool VimOptimizer<dim>::try_ring_swap(int a, int b, std::size_t m) {
  if constexpr (dim != 3) {
    return false;
  } else {
    std::vector<int>& ring = swap_ring_;
    std::vector<int>& p = swap_cycle_;
    if (!edge_ring<3>(adj_, mesh_.cells, a, b, m, ring, p)) return false;
    if (m == 3) {
      const Cell alt[2] = {Cell{p[0], p[1], p[2], a}, Cell{p[0], p[1], p[2], b}};
      return try_replace(ring.data(), 3, alt, 1, 2);
    }
    const Cell alt[8] = {Cell{p[0], p[2], p[1], a}, Cell{p[0], p[2], p[1], b}, Cell{p[0], p[2], p[3], a},
                         Cell{p[0], p[2], p[3], b}, Cell{p[1], p[3], p[0], a}, Cell{p[1], p[3], p[0], b},
                         Cell{p[1], p[3], p[2], a}, Cell{p[1], p[3], p[2], b}};
    return try_replace(ring.data(), 4, alt, 2, 4);
  }
}

template <int dim>
bool VimOptimizer<dim>::try_swap_32(int a, int b) {
  return try_ring_swap(a, b, 3);
}

template <int dim>
bool VimOptimizer<dim>::try_swap_44(int a, int b) {
  return try_ring_swap(a, b, 4);
}

// One sequential pass, in cell / node order (deterministic): facets (2D flips, 3D 2-3 swaps), then
// in 3D the interior edges with 3 (3-2 swap) or 4 (4-4 swap) cells.
template <int dim>
long VimOptimizer<dim>::swap_pass() {
  long swaps = 0;
  for (std::size_t c = 0; c < mesh_.cells.size(); ++c) {
    for (int k = 0; k <= dim; ++k) {
      if (!alive_[c]) break;
      const int nb = adj_.neighbor(static_cast<int>(c), mesh_.cells[c], k);
      if (nb < static_cast<int>(c)) continue;  // boundary, or the pair was tried from nb
      const bool taken = dim == 2 ? try_flip(static_cast<int>(c), k) : try_swap_23(static_cast<int>(c), k);
      if (taken) ++swaps;
    }
  }
  if constexpr (dim == 3) {
    std::vector<int> nbrs, ring;
    for (std::size_t a = 0; a < mesh_.points.size(); ++a) {
      nbrs.clear();
      for (int c : adj_.cells_of(static_cast<int>(a)))
        for (int w : mesh_.cells[c])
          if (w > static_cast<int>(a)) nbrs.push_back(w);
      std::sort(nbrs.begin(), nbrs.end());
      nbrs.erase(std::unique(nbrs.begin(), nbrs.end()), nbrs.end());
      for (int b : nbrs) {
        adj_.cells_with_edge(static_cast<int>(a), b, ring);
        if (ring.size() == 3 && try_swap_32(static_cast<int>(a), b))
          ++swaps;
        else if (ring.size() == 4 && try_swap_44(static_cast<int>(a), b))
          ++swaps;
      }
    }
  }
  return swaps;
}

template bool VimOptimizer<2>::try_replace(const int*, int, const Cell*, int, int);
template bool VimOptimizer<3>::try_replace(const int*, int, const Cell*, int, int);
template bool VimOptimizer<2>::try_facet_swap(int, int);
template bool VimOptimizer<3>::try_facet_swap(int, int);
template bool VimOptimizer<2>::try_ring_swap(int, int, std::size_t);
template bool VimOptimizer<3>::try_ring_swap(int, int, std::size_t);
template bool VimOptimizer<2>::try_flip(int, int);
template bool VimOptimizer<3>::try_flip(int, int);
template bool VimOptimizer<2>::try_swap_23(int, int);
template bool VimOptimizer<3>::try_swap_23(int, int);
template bool VimOptimizer<2>::try_swap_32(int, int);
template bool VimOptimizer<3>::try_swap_32(int, int);
template bool VimOptimizer<2>::try_swap_44(int, int);
template bool VimOptimizer<3>::try_swap_44(int, int);
template long VimOptimizer<2>::swap_pass();
template long VimOptimizer<3>::swap_pass();

}  // namespace vim

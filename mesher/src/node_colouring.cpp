// Node colouring for the parallel node updates of paper §IV-B: nodes of one colour share no
// element, so their 1-ring updates commute and run in parallel with results independent of the
// thread count (docs/architecture.md, "Determinism").
#include <vector>
#include <vim/optimizer.hpp>

namespace vim {

// Greedy colouring of the node graph in node order: a node gets the smallest colour not used by an
// already coloured neighbour. Nodes of one colour share no element, so their 1-rings are disjoint
// in cells and no node of the class is a vertex of another's 1-ring: their updates commute.
// Corner nodes (all axes fixed) are not scheduled.
template <int dim>
void VimOptimizer<dim>::recolour() {
  const std::size_t n = mesh_.points.size();
  std::vector<int> colour(n, -1);
  std::vector<char> used;
  colours_.clear();
  const std::uint8_t all = static_cast<std::uint8_t>((1u << dim) - 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (fixed_[i] == all || adj_.cells_of(static_cast<int>(i)).empty()) continue;
    used.assign(colours_.size() + 1, 0);
    for (int c : adj_.cells_of(static_cast<int>(i)))
      for (int v : mesh_.cells[c])
        if (colour[v] >= 0) used[colour[v]] = 1;
    int k = 0;
    while (used[k]) ++k;
    colour[i] = k;
    if (k == static_cast<int>(colours_.size())) colours_.emplace_back();
    colours_[k].push_back(static_cast<int>(i));
  }
}
template void VimOptimizer<2>::recolour();
template void VimOptimizer<3>::recolour();

}  // namespace vim

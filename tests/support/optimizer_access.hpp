// Test-only access to the VIM optimiser's internals (paper §IV-B): one node update run alone, the
// colour classes of the parallel node sweep and the box constraints of a node. Kept out of
// VimOptimizer's interface; the class names this struct as a friend.
#pragma once

#include <cstdint>
#include <vector>
#include <vim/optimizer.hpp>

namespace vim {

template <int dim>
struct OptimizerTestAccess {
  // Updates one node, as the sweep does (sequential use). Returns true if it moved.
  static bool update_node(VimOptimizer<dim>& o, int node, int iteration) {
    o.dirty_[node] = 0;
    const bool moved = o.update_node_impl(node, iteration, o.scratch_.local(), nullptr);
    if (moved) o.mark_ring_dirty(node);
    return moved;
  }
  // Colour classes of the node graph used by update_nodes (greedy, node order).
  static const std::vector<std::vector<int>>& colour_classes(const VimOptimizer<dim>& o) {
    return o.colours_;
  }
  // Bit a set: coordinate a of the node is fixed (the node lies on an axis-a face of the box).
  static std::uint8_t fixed_axes(const VimOptimizer<dim>& o, int node) { return o.fixed_[node]; }
};

}  // namespace vim

// Mesh segmentation of paper §VI-B: threshold the element values, group the elements above the
// threshold into face-connected components, and flag the largest component (by volume) as "the object".
#pragma once

#include <vector>
#include <vim/simplex_mesh.hpp>
#include <vim/vim.hpp>

namespace vim {

struct Segmentation {
  std::vector<int>
      component;  // per cell: component id (0, 1, ... in order of lowest cell index), -1 if mean <= threshold
  std::vector<bool> object;  // per cell: belongs to the largest component
  int n_components = 0;
  int largest = -1;             // id of the largest component by volume (ties: smallest id); -1 if none
  long largest_size = 0;        // its cell count
  double largest_volume = 0.0;  // its volume
};

// Components connect cells that share a facet (dim vertices). values.size() must equal the cell count.
template <int dim>
Segmentation segment(const SimplexMesh<dim>& mesh, const std::vector<ElementValue>& values, double threshold);

}  // namespace vim

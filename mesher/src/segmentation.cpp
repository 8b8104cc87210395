// Segmentation of paper §VI-B: elements with mean > threshold, face-connected components (facets
// matched by vim::match_facets), the largest component flagged as the object.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vim/facets.hpp>
#include <vim/segmentation.hpp>

namespace vim {

template <int dim>
Segmentation segment(const SimplexMesh<dim>& mesh, const std::vector<ElementValue>& values,
                     double threshold) {
  const std::size_t nc = mesh.n_cells();
  if (values.size() != nc)
    throw std::invalid_argument("values: expected one ElementValue per cell (" + std::to_string(nc) +
                                "), got " + std::to_string(values.size()));
  Segmentation seg;
  seg.component.assign(nc, -1);
  seg.object.assign(nc, false);

  // Cells above the threshold sharing a facet are neighbours (consecutive users of one facet).
  std::vector<char> above(nc);
  for (std::size_t c = 0; c < nc; ++c) above[c] = values[c].mean > threshold;
  const FacetIncidence<dim> facets = match_facets<dim>(mesh.n_points(), mesh.cells, above);
  std::vector<std::vector<int>> adjacent(nc);
  for (std::size_t k = 0; k + 1 < facets.uses.size(); ++k)
    if (facets.uses[k].vertices == facets.uses[k + 1].vertices) {
      const int c0 = static_cast<int>(facets.uses[k].cell()),
                c1 = static_cast<int>(facets.uses[k + 1].cell());
      adjacent[c0].push_back(c1);
      adjacent[c1].push_back(c0);
    }

  std::vector<long> sizes;
  std::vector<double> volumes;
  std::vector<int> stack;
  for (std::size_t c = 0; c < nc; ++c) {
    if (!(values[c].mean > threshold) || seg.component[c] >= 0) continue;
    const int id = seg.n_components++;
    long size = 0;
    double volume = 0.0;
    seg.component[c] = id;
    stack.assign(1, static_cast<int>(c));
    while (!stack.empty()) {
      const int u = stack.back();
      stack.pop_back();
      ++size;
      volume += std::abs(signed_volume<dim>(cell_points(mesh, static_cast<std::size_t>(u))));
      for (int w : adjacent[u])
        if (seg.component[w] < 0) {
          seg.component[w] = id;
          stack.push_back(w);
        }
    }
    sizes.push_back(size);
    volumes.push_back(volume);
  }
  // The largest by volume (an adaptive mesh's element count says little about size); a component
  // within 1e-12 of the largest so far does not replace it, so ties go to the smallest id.
  for (int id = 0; id < seg.n_components; ++id)
    if (seg.largest < 0 || volumes[id] > seg.largest_volume * (1.0 + 1e-12)) {
      seg.largest = id;
      seg.largest_size = sizes[id];
      seg.largest_volume = volumes[id];
    }
  for (std::size_t c = 0; c < nc; ++c) seg.object[c] = seg.largest >= 0 && seg.component[c] == seg.largest;
  return seg;
}

template Segmentation segment<2>(const SimplexMesh<2>&, const std::vector<ElementValue>&, double);
template Segmentation segment<3>(const SimplexMesh<3>&, const std::vector<ElementValue>&, double);

}  // namespace vim

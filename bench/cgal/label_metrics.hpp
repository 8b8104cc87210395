// Independent scoring of label meshes (docs/cgal_comparison.md, "Labels"): which element holds each
// voxel centre (brute-force barycentric test of bench/metrics.hpp, each voxel once: the first element
// in cell order that holds it), the majority label of each element, and per label the misclassified
// voxels (centre in an element of another label). Reads only the mesh, the cell labels and the image.
#pragma once

#include <cmath>
#include <map>
#include <vector>

#include "../metrics.hpp"

namespace vim::metrics {

// Owner element of every voxel centre (-1: in no element).
template <int dim>
std::vector<int> voxel_owners(const Image<dim>& image, const SimplexMesh<dim>& mesh, double tol = 1e-9) {
  std::vector<int> owner(image.voxel_count(), -1);
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    for_each_voxel_in<dim>(image, cell_points(mesh, c), tol, [&](std::size_t k) {
      if (owner[k] < 0) owner[k] = static_cast<int>(c);
    });
  return owner;
}

// Each element's label: most of its voxel centres (ties: the smallest label); an element holding
// none takes the label of the voxel whose centre is nearest its centroid.
template <int dim>
std::vector<int> majority_labels(const Image<dim>& image, const SimplexMesh<dim>& mesh,
                                 const std::vector<int>& owner) {
  std::vector<std::map<int, long>> counts(mesh.n_cells());
  for (std::size_t k = 0; k < owner.size(); ++k)
    if (owner[k] >= 0)
      ++counts[static_cast<std::size_t>(owner[k])][static_cast<int>(std::lround(image.data[k]))];
  std::vector<int> label(mesh.n_cells());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    long best = 0;
    for (const auto& [l, n] : counts[c])  // ascending: a strict > keeps the smallest on a tie
      if (n > best) best = n, label[c] = l;
    if (best > 0) continue;
    Pt<dim> g = Pt<dim>::Zero();
    for (const auto& p : cell_points(mesh, c)) g += p / (dim + 1.0);
    typename Image<dim>::Index i;
    for (int a = 0; a < dim; ++a) {
      const double ci = (g[a] - image.origin[a]) / image.spacing[a];
      i[a] = std::lround(std::clamp(ci, 0.0, static_cast<double>(image.size[a] - 1)));
    }
    label[c] = static_cast<int>(std::lround(image.at(i)));
  }
  return label;
}

// Per label: its voxel centres, those in an element of another label, those in no element.
struct LabelScore {
  std::map<int, long> voxels, misclassified, uncovered;
  long total_misclassified() const {
    long n = 0;
    for (const auto& kv : misclassified) n += kv.second;
    return n;
  }
};

template <int dim>
LabelScore label_score(const Image<dim>& image, const std::vector<int>& owner,
                       const std::vector<int>& cell_label) {
  LabelScore s;
  for (std::size_t k = 0; k < owner.size(); ++k) {
    const int l = static_cast<int>(std::lround(image.data[k]));
    ++s.voxels[l];
    s.misclassified[l] += owner[k] >= 0 && cell_label[static_cast<std::size_t>(owner[k])] != l ? 1 : 0;
    s.uncovered[l] += owner[k] < 0 ? 1 : 0;
  }
  return s;
}

}  // namespace vim::metrics

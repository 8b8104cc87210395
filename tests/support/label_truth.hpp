// Independent truth for label meshes (tests only; no mesher code): which element holds each voxel
// centre, by barycentric coordinates of the centre nudged by the documented tie rule (towards the
// image centre, then along the axes), the per-element label counts, the majority rule
// (ties: smallest label; no voxel centre: the voxel nearest the centroid), the label data term
// Σ_l p_l(1 − p_l) and the misclassified volume (voxels whose centre lies in an element of another
// label, times the voxel volume).
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

#include "voxel_owner.hpp"

namespace vim::test {

// Owner element of every voxel centre (-1: none). Works in continuous index space; a centre is moved
// by 1e-8 towards the image centre plus 1e-10, 1e-11, 1e-12 along the axes before the strict
// barycentric test, which decides the centres on shared faces the way the mesher's tie rule does.
template <int dim>
std::vector<int> label_owner(const Image<dim>& img, const SimplexMesh<dim>& mesh) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  Vec centre;
  for (int a = 0; a < dim; ++a) centre[a] = 0.5 * static_cast<double>(img.size[a] - 1);
  const auto nudged = [&](const typename Image<dim>::Index& j) {
    Vec p;
    for (int a = 0; a < dim; ++a) p[a] = static_cast<double>(j[a]);
    Vec d = centre - p;
    if (d.norm() > 0.0) d /= d.norm();
    Vec q = p + 1e-8 * d;
    for (int a = 0; a < dim; ++a) q[a] += std::pow(10.0, -10 - a);
    return q;
  };
  return voxel_owner(img, mesh, 1, nudged, [](const Vec& b) { return b.minCoeff() > 0.0 && b.sum() < 1.0; });
}

// Per element: label → number of voxel centres it holds.
template <int dim>
std::vector<std::map<int, long>> label_counts(const Image<dim>& img, const std::vector<int>& owner,
                                              std::size_t cells) {
  std::vector<std::map<int, long>> counts(cells);
  for (std::size_t k = 0; k < owner.size(); ++k)
    if (owner[k] >= 0) ++counts[static_cast<std::size_t>(owner[k])][static_cast<int>(img.data[k])];
  return counts;
}

// The majority label of each element (ties: smallest; none: the voxel nearest the centroid).
template <int dim>
std::vector<int> majority_labels(const Image<dim>& img, const SimplexMesh<dim>& mesh,
                                 const std::vector<std::map<int, long>>& counts) {
  std::vector<int> out(mesh.n_cells());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    long best = 0;
    int label = 0;
    for (const auto& [l, n] : counts[c])  // ascending labels: a strict > keeps the smallest on a tie
      if (n > best) best = n, label = l;
    if (best == 0) {
      Eigen::Matrix<double, dim, 1> g = Eigen::Matrix<double, dim, 1>::Zero();
      for (int k = 0; k <= dim; ++k) g += mesh.points[static_cast<std::size_t>(mesh.cells[c][k])];
      g /= dim + 1.0;
      const auto ci = img.continuous_index(g);
      typename Image<dim>::Index i;
      for (int a = 0; a < dim; ++a)
        i[a] = std::lround(std::clamp(ci[a], 0.0, static_cast<double>(img.size[a] - 1)));
      label = static_cast<int>(img.at(i));
    }
    out[c] = label;
  }
  return out;
}

// Σ_l p_l (1 − p_l) of one element's counts (0 for none).
inline double gini(const std::map<int, long>& counts) {
  long n = 0;
  for (const auto& kv : counts) n += kv.second;
  if (n == 0) return 0.0;
  double s = 0.0;
  for (const auto& kv : counts) {
    const double p = static_cast<double>(kv.second) / static_cast<double>(n);
    s += p * (1.0 - p);
  }
  return s;
}

// Volume of the voxels whose centre lies in an element of another label (per label of the voxel).
template <int dim>
std::map<int, double> misclassified_volume(const Image<dim>& img, const std::vector<int>& owner,
                                           const std::vector<int>& element_label) {
  double voxel = 1.0;
  for (int a = 0; a < dim; ++a) voxel *= img.spacing[a];
  std::map<int, double> out;
  for (std::size_t k = 0; k < owner.size(); ++k) {
    const int l = static_cast<int>(img.data[k]);
    out[l] += 0.0;
    if (owner[k] < 0 || element_label[static_cast<std::size_t>(owner[k])] != l) out[l] += voxel;
  }
  return out;
}

inline double total(const std::map<int, double>& per_label) {
  double s = 0.0;
  for (const auto& kv : per_label) s += kv.second;
  return s;
}

// The misclassified volume of a label mesh, its elements whose label is not the majority, and the
// voxel centres no element holds.
struct LabelFit {
  double misclassified = 0.0;
  long wrong_majority = 0;
  long outside = 0;
};

template <int dim>
LabelFit label_fit(const Image<dim>& img, const SimplexMesh<dim>& mesh, const std::vector<int>& labels) {
  const auto owner = label_owner(img, mesh);
  const auto counts = label_counts(img, owner, mesh.n_cells());
  const auto truth = majority_labels(img, mesh, counts);
  LabelFit f;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) f.wrong_majority += labels[c] != truth[c];
  f.misclassified = total(misclassified_volume(img, owner, labels));
  f.outside = std::count(owner.begin(), owner.end(), -1);
  return f;
}

}  // namespace vim::test

// A straight needle path and the mesh density that refines the mesh along needle paths (paper §VI-E
// sizing; the scenario's mesh.needle_refinement).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <vector>
#include <vim/image.hpp>

namespace vim::needle {

// A straight needle path in frame coordinates: the segment from `entry` to `entry + depth·axis`.
template <int dim>
struct NeedlePath {
  Eigen::Matrix<double, dim, 1> entry, axis;  // axis of unit length
  double depth = 0.0;
  double distance(const Eigen::Matrix<double, dim, 1>& p) const {
    const double s = std::clamp((p - entry).dot(axis), 0.0, depth);
    return (p - entry - s * axis).norm();
  }
};

// Mesh density for needle-path refinement (paper §VI-E sizing), on the grid of `like` (frame
// coordinates): ρ(x) = 1 + (ρ_max − 1)·exp(−(d(x)/radius)²), d = distance to the nearest path,
// ρ_max = size_ratio^−(dim+2). Weighting E_G by ρ makes the optimal element size (where the image
// is uniform) ∝ ρ^(−1/(dim+2)), so elements on a path are about size_ratio times the size of elements
// far from every path. Throws std::invalid_argument unless 0 < size_ratio <= 1, radius > 0 and
// there is at least one path.
template <int dim>
Image<dim> needle_density(const Image<dim>& like, const std::vector<NeedlePath<dim>>& paths,
                          double size_ratio, double radius);

}  // namespace vim::needle

// Voxel statistics of a label image (docs/labels.md): per element the voxel centres of each label,
// the label data term Σ_l var(1_l) (the variance of every label's indicator, summed) and the
// majority rule that gives each element its label. Built on VoxelStatistics (the same enclosure
// and tie rule), one instance per label indicator plus one of the label values themselves.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <vector>
#include <vim/image.hpp>
#include <vim/voxel_statistics.hpp>

namespace vim {

template <int dim>
class LabelStatistics {
 public:
  using Point = Eigen::Matrix<double, dim, 1>;
  using Simplex = std::array<Point, dim + 1>;

  // At most this many distinct labels (each costs one indicator's prefix sums).
  static constexpr std::size_t kMaxLabels = 64;

  // `labels` holds integer values (float storage); throws std::invalid_argument naming the first
  // voxel (index and value) that is not an integer, or the count if there are more than kMaxLabels.
  explicit LabelStatistics(const Image<dim>& labels);

  // The distinct labels, ascending.
  const std::vector<int>& labels() const { return labels_; }
  // Statistics of the label values as a scalar image: their variance in a set of voxels is 0 iff
  // every voxel holds the same label (the optimiser's uniformity tests use it).
  const VoxelStatistics<dim>& values() const { return *values_; }
  const Image<dim>& image() const { return *image_; }

  // Σ_l var(1_l) = Σ_l p_l (1 − p_l), p_l = n_l / n, over the voxel centres in x; 0 if x holds none.
  double indicator_variance(const Simplex& x) const;
  // n_l for every label (labels() order) over the voxel centres in x.
  void counts(const Simplex& x, std::vector<long>& out) const;
  // The majority rule: the label of most of the voxel centres in x, the smallest on a tie; an
  // element holding no voxel centre takes the label of the voxel nearest its centroid.
  int majority(const Simplex& x) const;
  // The label of the voxel whose centre is nearest p (clamped to the image).
  int label_at(const Point& p) const;

 private:
  const Image<dim>* image_;
  std::vector<int> labels_;
  std::vector<std::unique_ptr<Image<dim>>> indicators_;  // 1 where the voxel holds labels_[l]
  std::vector<std::unique_ptr<VoxelStatistics<dim>>> indicator_stats_;
  std::unique_ptr<VoxelStatistics<dim>> values_;
};

extern template class LabelStatistics<2>;
extern template class LabelStatistics<3>;

}  // namespace vim

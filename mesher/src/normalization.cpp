// Normalisation of paper §IV-C: E_G0 and E_D0 from the initial mesh, fixed for the whole run, so
// that E = (1−λ)·E_G/E_G0 + λ·E_D/E_D0 (Eq. 7) weighs relative gains; E_D0 is estimated when the
// initial mesh fits a varying image exactly (E_D = 0 would switch the image term off).
#include <cmath>
#include <map>
#include <vim/energy.hpp>
#include <vim/optimizer.hpp>

namespace vim {

namespace {

// Whether the centre of voxel idx lies in [box_min, box_max] (within tol).
template <int dim>
bool inside_box(const Image<dim>& img, const typename Image<dim>::Index& idx,
                const Eigen::Matrix<double, dim, 1>& box_min, const Eigen::Matrix<double, dim, 1>& box_max,
                double tol) {
  for (int a = 0; a < dim; ++a) {
    const double x = img.origin[a] + static_cast<double>(idx[a]) * img.spacing[a];
    if (!(x >= box_min[a] - tol && x <= box_max[a] + tol)) return false;
  }
  return true;
}

// Population variance of the voxel values whose centres lie in [box_min, box_max] (within tol);
// 0 for a constant set (element_variance's snapping).
template <int dim>
double box_variance(const Image<dim>& img, const Eigen::Matrix<double, dim, 1>& box_min,
                    const Eigen::Matrix<double, dim, 1>& box_max, double tol) {
  long n = 0;
  double first = 0.0, s = 0.0, q = 0.0;
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    if (!inside_box<dim>(img, img.index_of(k), box_min, box_max, tol)) continue;
    const double h = static_cast<double>(img.data[k]);
    if (n == 0) first = h;
    ++n;
    s += h - first;
    q += (h - first) * (h - first);
  }
  return element_variance(n, s, q);
}

// Σ_l p_l (1 − p_l) over the labels of the voxels whose centres lie in [box_min, box_max]: the label
// data term's variance of that voxel set (LabelStatistics::indicator_variance).
template <int dim>
double box_indicator_variance(const Image<dim>& img, const Eigen::Matrix<double, dim, 1>& box_min,
                              const Eigen::Matrix<double, dim, 1>& box_max, double tol) {
  std::map<float, long> count;
  long n = 0;
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    if (!inside_box<dim>(img, img.index_of(k), box_min, box_max, tol)) continue;
    ++count[img.data[k]];
    ++n;
  }
  double sum = 0.0;
  for (const auto& [label, nl] : count)
    sum += static_cast<double>(nl) * static_cast<double>(n - nl) / (static_cast<double>(n) * n);
  return sum;
}

}  // namespace

template <int dim>
void VimOptimizer<dim>::fix_normalization() {
  const EnergyTotals t = totals();
  eg0_ = t.geometric > 0.0 ? t.geometric : 1.0;
  ed0_ = t.discretization;
  ed0_estimated_ = false;
  if (!(ed0_ > 0.0) && stats_ != nullptr && options_.lambda > 0.0) {
    // E_D = 0 although the image may vary inside the box: every element holds voxel centres of one
    // value (its faces lie on the image's edges, or it is no larger than a voxel). Normalising by 0
    // would switch the image term off, and E_G alone would then pull an exact fit apart. E_D0 is
    // instead the E_D a mesh of this size typically has: the box's own E_D as one element,
    // |Ω|·var(Ω) (an upper bound of any mesh's E_D), times the element width over the box width,
    // m^(−1/d) for m elements (E_D grows with the width of the elements cut by the image's edges).
    // A constant image keeps E_D0 = 0.
    const double tol = 1e-9 * bbox_diagonal();
    const double var = labels_ ? box_indicator_variance<dim>(stats_->image(), box_min_, box_max_, tol)
                               : box_variance<dim>(stats_->image(), box_min_, box_max_, tol);
    if (var > 0.0 && n_live_ > 0) {
      double volume = 1.0;
      for (int a = 0; a < dim; ++a) volume *= box_max_[a] - box_min_[a];
      ed0_ = volume * var * std::pow(static_cast<double>(n_live_), -1.0 / dim);
      ed0_estimated_ = true;
    }
  }
  EnergyNormalization norm{eg0_, ed0_, options_.lambda};
  // cost = (1−λ)·E_G/E_G0 + λ·E_D/E_D0 per element, the same weights as EnergyNormalization.
  wg_ = norm.combined(1.0, 0.0);
  wd_ = ed0_ > 0.0 ? norm.combined(0.0, 1.0) : 0.0;
  for (std::size_t c = 0; c < cache_.size(); ++c)
    if (alive_[c]) cache_[c].cost = cost_of(cache_[c]);
}

template void VimOptimizer<2>::fix_normalization();
template void VimOptimizer<3>::fix_normalization();

}  // namespace vim

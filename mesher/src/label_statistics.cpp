// Label statistics (docs/labels.md): one VoxelStatistics per label indicator gives n_l, the voxel
// centres of label l in an element, by the scanline sums of the grey-value term; the label data
// term Σ_l n_l (n − n_l) / n² and the majority rule are computed from these integer counts.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/label_statistics.hpp>

namespace vim {

namespace {

// n_l from an indicator's shifted sum S = Σ (1_l − shift) over n voxel centres: S + n·shift, an
// integer up to round-off far below 0.5.
long indicator_count(const VoxelStatistics<2>::Sums& s, double shift) {
  return std::lround(s.s + static_cast<double>(s.n) * shift);
}
long indicator_count(const VoxelStatistics<3>::Sums& s, double shift) {
  return std::lround(s.s + static_cast<double>(s.n) * shift);
}

}  // namespace

template <int dim>
LabelStatistics<dim>::LabelStatistics(const Image<dim>& labels) : image_(&labels) {
  std::vector<int> found;
  for (std::size_t k = 0; k < labels.data.size(); ++k) {
    const float v = labels.data[k];
    if (!(std::isfinite(v) && v == std::round(v) && std::abs(v) < 2.0e9f)) {
      std::ostringstream m;
      const auto i = labels.index_of(k);
      m << "label image: voxel (";
      for (int a = 0; a < dim; ++a) m << (a ? "," : "") << i[a];
      m << ") holds " << v << ", not an integer label";
      throw std::invalid_argument(m.str());
    }
    const int l = static_cast<int>(v);
    if (std::find(found.begin(), found.end(), l) == found.end()) {
      found.push_back(l);
      if (found.size() > kMaxLabels)
        throw std::invalid_argument("label image: more than " + std::to_string(kMaxLabels) +
                                    " distinct labels");
    }
  }
  std::sort(found.begin(), found.end());
  labels_ = found;
  values_ = std::make_unique<VoxelStatistics<dim>>(labels);
  for (int l : labels_) {
    auto ind = std::make_unique<Image<dim>>(labels.size, labels.spacing, labels.origin, 0.0f);
    for (std::size_t k = 0; k < labels.data.size(); ++k)
      ind->data[k] = static_cast<int>(labels.data[k]) == l ? 1.0f : 0.0f;
    indicator_stats_.push_back(std::make_unique<VoxelStatistics<dim>>(*ind));
    indicators_.push_back(std::move(ind));
  }
}

template <int dim>
double LabelStatistics<dim>::indicator_variance(const Simplex& x) const {
  // A label whose indicator is constant over x's index box contributes p_l ∈ {0, 1}, i.e. nothing;
  // every scanned indicator sees the same voxel set, so n is the same for all of them.
  long numerator = 0, n = 0;
  for (std::size_t l = 0; l < labels_.size(); ++l) {
    typename VoxelStatistics<dim>::Sums s;
    if (!indicator_stats_[l]->varied_sums(x, s) || s.n == 0) continue;
    const long nl = indicator_count(s, indicator_stats_[l]->shift());
    numerator += nl * (s.n - nl);
    n = s.n;
  }
  if (n == 0) return 0.0;
  const double nn = static_cast<double>(n);
  return static_cast<double>(numerator) / (nn * nn);
}

template <int dim>
void LabelStatistics<dim>::counts(const Simplex& x, std::vector<long>& out) const {
  out.assign(labels_.size(), 0);
  for (std::size_t l = 0; l < labels_.size(); ++l)
    out[l] = indicator_count(indicator_stats_[l]->sums(x), indicator_stats_[l]->shift());
}

template <int dim>
int LabelStatistics<dim>::majority(const Simplex& x) const {
  std::vector<long> n;
  counts(x, n);
  std::size_t best = 0;
  for (std::size_t l = 1; l < n.size(); ++l)
    if (n[l] > n[best]) best = l;  // strict: a tie keeps the smaller label
  if (n.empty() || n[best] == 0) return label_at(centroid<dim>(x));
  return labels_[best];
}

template <int dim>
int LabelStatistics<dim>::label_at(const Point& p) const {
  const Point c = image_->continuous_index(p);
  typename Image<dim>::Index i;
  for (int a = 0; a < dim; ++a) {
    const double r = std::round(std::min(std::max(c[a], 0.0), static_cast<double>(image_->size[a] - 1)));
    i[a] = static_cast<long>(r);
  }
  return static_cast<int>(image_->at(i));
}

template class LabelStatistics<2>;
template class LabelStatistics<3>;

}  // namespace vim

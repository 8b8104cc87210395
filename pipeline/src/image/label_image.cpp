// Label images (label_image.hpp): the integer check, the labels present and the nearest-neighbour
// resampling into the modulus image's grid.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <vim/pipeline/image/label_image.hpp>

namespace vim::pipeline {

template <int dim>
void check_label_image(const Image<dim>& labels, const std::string& file) {
  for (std::size_t k = 0; k < labels.data.size(); ++k) {
    const float v = labels.data[k];
    if (v == std::round(v) && std::abs(v) < 2.0e9f) continue;
    const auto i = labels.index_of(k);
    std::ostringstream m;
    m << file << ": voxel (";
    for (int a = 0; a < dim; ++a) m << (a ? "," : "") << i[a];
    m << ") holds " << v << ", not an integer label; a label image holds integers (a segmentation)";
    throw InputError(m.str());
  }
}

template <int dim>
std::vector<int> labels_present(const Image<dim>& labels) {
  std::vector<int> out;
  for (float v : labels.data) {
    const int l = static_cast<int>(v);
    if (std::find(out.begin(), out.end(), l) == out.end()) out.push_back(l);
  }
  std::sort(out.begin(), out.end());
  return out;
}

template <int dim>
Image<dim> labels_in_grid_of(const OrientedImage<dim>& reference, const OrientedImage<dim>& labels,
                             const std::string& file) {
  using Point = Eigen::Matrix<double, dim, 1>;
  // The overlap test: the world box of the label image's voxel domain (its 2^dim corners) in the
  // reference's frame, against the reference's box.
  const Point lo = labels.image.box_min(), hi = labels.image.box_max();
  Point flo, fhi;
  for (int corner = 0; corner < (1 << dim); ++corner) {
    Point p;
    for (int a = 0; a < dim; ++a) p[a] = (corner >> a) & 1 ? hi[a] : lo[a];
    const Point f = reference.to_frame(labels.to_world(p));
    flo = corner ? flo.cwiseMin(f) : f;
    fhi = corner ? fhi.cwiseMax(f) : f;
  }
  const Point rlo = reference.image.box_min(), rhi = reference.image.box_max();
  for (int a = 0; a < dim; ++a)
    if (!(flo[a] < rhi[a] && fhi[a] > rlo[a])) {
      std::ostringstream m;
      m << file << ": the label image does not overlap the modulus image (along the modulus image's axis "
        << a << " it covers [" << flo[a] << ", " << fhi[a] << "], the modulus image [" << rlo[a] << ", "
        << rhi[a] << "]); give a label image of the same region";
      throw InputError(m.str());
    }
  Image<dim> out(reference.image.size, reference.image.spacing, reference.image.origin, 0.0f);
  for (std::size_t k = 0; k < out.data.size(); ++k) {
    const Point c =
        labels.image.continuous_index(labels.to_frame(reference.to_world(out.point_of(out.index_of(k)))));
    typename Image<dim>::Index i;
    for (int a = 0; a < dim; ++a)
      i[a] =
          static_cast<long>(std::round(std::clamp(c[a], 0.0, static_cast<double>(labels.image.size[a] - 1))));
    out.data[k] = labels.image.at(i);
  }
  return out;
}

template void check_label_image<2>(const Image<2>&, const std::string&);
template void check_label_image<3>(const Image<3>&, const std::string&);
template std::vector<int> labels_present<2>(const Image<2>&);
template std::vector<int> labels_present<3>(const Image<3>&);
template Image<2> labels_in_grid_of<2>(const OrientedImage<2>&, const OrientedImage<2>&, const std::string&);
template Image<3> labels_in_grid_of<3>(const OrientedImage<3>&, const OrientedImage<3>&, const std::string&);

}  // namespace vim::pipeline

// Image IO (see image_io.hpp): converts between the ITK side (itk_image_io.cpp, plain arrays, no
// Eigen) and OrientedImage<dim>, and checks what needs the voxels (NaN/Inf) or the geometry
// (an orthonormal direction matrix).
#include <Eigen/LU>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/pipeline/image/image_arrays.hpp>

#include "image/itk_image_io.hpp"

namespace vim::pipeline {

int image_dimension(const std::string& path) { return itk_io::header_dimension(path); }

template <int dim>
Image<dim> in_frame_of(const OrientedImage<dim>& reference, const OrientedImage<dim>& other) {
  if (!other.direction.isApprox(reference.direction, 1e-6))
    throw std::invalid_argument("in_frame_of: the images' direction matrices differ");
  // other's frame point of world w = reference.to_world(p) is p + (Dᵀ − I)(o_ref − o_other).
  using Matrix = Eigen::Matrix<double, dim, dim>;
  const Eigen::Matrix<double, dim, 1> shift =
      (reference.direction.transpose() - Matrix::Identity()) * (reference.origin() - other.origin());
  Image<dim> out = other.image;
  for (int a = 0; a < dim; ++a) out.origin[a] -= shift[a];
  return out;
}
template Image<2> in_frame_of<2>(const OrientedImage<2>&, const OrientedImage<2>&);
template Image<3> in_frame_of<3>(const OrientedImage<3>&, const OrientedImage<3>&);

template <int dim>
OrientedImage<dim> oriented_image(const std::vector<long>& size, const std::vector<double>& spacing,
                                  const std::vector<double>& origin, const std::vector<double>& direction,
                                  std::vector<float> data, const std::string& path, bool double_voxels) {
  OrientedImage<dim> out;
  for (int a = 0; a < dim; ++a) {
    out.image.size[a] = size[a];
    out.image.spacing[a] = spacing[a];
    out.image.origin[a] = origin[a];
    for (int b = 0; b < dim; ++b) out.direction(a, b) = direction[a * dim + b];
  }
  out.image.data = std::move(data);

  const std::size_t n = out.image.data.size();
  long bad = 0;
  std::size_t first = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(out.image.data[k]) && bad++ == 0) first = k;
  if (bad > 0) {
    const auto idx = out.image.index_of(first);
    std::ostringstream m;
    m << path << ": " << bad << " voxel" << (bad > 1 ? "s are" : " is") << " NaN or Inf (first at index (";
    for (int a = 0; a < dim; ++a) m << (a ? "," : "") << idx[a];
    m << ")); every voxel must be a finite number";
    if (double_voxels)
      m << " (the file stores doubles: a finite value beyond ±3.4e38, the largest a float voxel can hold, "
           "also reads"
           " as Inf; rescale the image)";
    throw InputError(m.str());
  }

  const double det = out.direction.determinant();
  const double orth =
      (out.direction.transpose() * out.direction - Eigen::Matrix<double, dim, dim>::Identity())
          .cwiseAbs()
          .maxCoeff();
  if (!std::isfinite(det) || std::abs(std::abs(det) - 1.0) > 1e-3 || orth > 1e-3) {
    std::ostringstream m;
    m << path << ": direction matrix is not orthonormal (|det| = " << std::abs(det)
      << ", largest |DᵀD − I| entry " << orth
      << "); expected a rotation or reflection (unit, mutually perpendicular axes)";
    throw InputError(m.str());
  }
  return out;
}
template OrientedImage<2> oriented_image<2>(const std::vector<long>&, const std::vector<double>&,
                                            const std::vector<double>&, const std::vector<double>&,
                                            std::vector<float>, const std::string&, bool);
template OrientedImage<3> oriented_image<3>(const std::vector<long>&, const std::vector<double>&,
                                            const std::vector<double>&, const std::vector<double>&,
                                            std::vector<float>, const std::string&, bool);

ImageFile::ImageFile(std::string path) : path_(std::move(path)), header_(itk_io::read_header(path_)) {
  dimension_ = itk_io::dimension(*header_);
}

template <int dim>
OrientedImage<dim> ImageFile::read() const {
  // ITK's reader keeps state in its ImageIO: a second read starts from a fresh header.
  if (used_) header_ = itk_io::read_header(path_);
  used_ = true;
  itk_io::RawImage raw = itk_io::read(*header_, dim);
  return oriented_image<dim>(raw.size, raw.spacing, raw.origin, raw.direction, std::move(raw.data), path_,
                             raw.double_voxels);
}

template <int dim>
OrientedImage<dim> read_image(const std::string& path) {
  return ImageFile(path).read<dim>();
}

namespace {
template <int dim>
itk_io::RawImage raw_of(const OrientedImage<dim>& image) {
  itk_io::RawImage raw;
  for (int a = 0; a < dim; ++a) {
    raw.size.push_back(image.image.size[a]);
    raw.spacing.push_back(image.image.spacing[a]);
    raw.origin.push_back(image.image.origin[a]);
    for (int b = 0; b < dim; ++b) raw.direction.push_back(image.direction(a, b));
  }
  raw.data = image.image.data;
  return raw;
}
}  // namespace

template <int dim>
void write_image(const OrientedImage<dim>& image, const std::string& path) {
  itk_io::write(raw_of(image), path);
}

template <int dim>
void write_label_image(const OrientedImage<dim>& labels, const std::string& path) {
  itk_io::RawImage raw = raw_of(labels);
  raw.labels = true;
  itk_io::write(raw, path);
}

template OrientedImage<2> ImageFile::read<2>() const;
template OrientedImage<3> ImageFile::read<3>() const;
template OrientedImage<2> read_image<2>(const std::string&);
template OrientedImage<3> read_image<3>(const std::string&);
template void write_image<2>(const OrientedImage<2>&, const std::string&);
template void write_image<3>(const OrientedImage<3>&, const std::string&);
template void write_label_image<2>(const OrientedImage<2>&, const std::string&);
template void write_label_image<3>(const OrientedImage<3>&, const std::string&);

}  // namespace vim::pipeline

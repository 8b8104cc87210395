// Image IO through ITK: MetaImage (.mha/.mhd), NRRD, NIfTI; any scalar pixel type read as float.
// The voxel grid goes to the mesher as Image<dim> (axis-aligned physical frame); the direction
// matrix stays here and is applied to every output (world = origin + D·(p − origin)).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>  // OrientedImage::to_frame
#include <memory>
#include <stdexcept>
#include <string>
#include <vim/image.hpp>
#include <vim/pipeline/common/input_error.hpp>

namespace vim::pipeline {

// InputError (input_error.hpp): one clear message naming the file and the problem (exit 1).
// Note: ITK headers bundle Eigen 3.3 and clash with the system Eigen 3.4 that this header pulls in;
// ITK code lives in Eigen-free translation units (src/itk_image_io.cpp).

template <int dim>
struct OrientedImage {
  Image<dim> image;
  Eigen::Matrix<double, dim, dim> direction = Eigen::Matrix<double, dim, dim>::Identity();

  using Point = Eigen::Matrix<double, dim, 1>;
  Point origin() const {
    Point o;
    for (int a = 0; a < dim; ++a) o[a] = image.origin[a];
    return o;
  }
  // Axis-aligned physical frame (the mesher's) -> world (ITK physical point, as Slicer shows it).
  Point to_world(const Point& p) const { return origin() + direction * (p - origin()); }
  Point to_frame(const Point& w) const { return origin() + direction.inverse() * (w - origin()); }
};

// `other`'s voxels as an Image in `reference`'s axis-aligned frame, for images that share a direction
// matrix but not an origin (each frame is turned about its own image's origin): the origin is moved so
// that the frame point p of `reference` falls in the voxel of `other` at world point reference.to_world(p).
// Throws std::invalid_argument if the directions differ.
template <int dim>
Image<dim> in_frame_of(const OrientedImage<dim>& reference, const OrientedImage<dim>& other);

// Number of spatial dimensions in the file's header (2 or 3); throws InputError otherwise.
int image_dimension(const std::string& path);

namespace itk_io {
struct Header;
}

// An image file whose header has been read and checked once (existence, format, dimension 2 or 3,
// scalar pixels, size, spacing, origin): the dimension is known before the voxels are read, which
// read() then does without opening the header again. Throws InputError naming the file.
class ImageFile {
 public:
  explicit ImageFile(std::string path);
  const std::string& path() const { return path_; }
  int dimension() const { return dimension_; }
  // The voxels and geometry (the checks of read_image); InputError if dim != dimension().
  template <int dim>
  OrientedImage<dim> read() const;

 private:
  std::string path_;
  mutable std::shared_ptr<itk_io::Header> header_;
  mutable bool used_ = false;
  int dimension_ = 0;
};

// Reads a scalar image; throws InputError for a missing/unreadable file, an unsupported format,
// vector pixels, an empty image, NaN/Inf voxels or non-positive spacing.
template <int dim>
OrientedImage<dim> read_image(const std::string& path);

// Writes a float image (.mha, .nrrd, .nii[.gz] by extension) through a temporary name + rename.
template <int dim>
void write_image(const OrientedImage<dim>& image, const std::string& path);
// Writes a label image (integer values, stored as 16-bit signed integers) in the same way; throws
// std::invalid_argument for a value that is not an integer in [−32767, 32767].
template <int dim>
void write_label_image(const OrientedImage<dim>& labels, const std::string& path);

}  // namespace vim::pipeline

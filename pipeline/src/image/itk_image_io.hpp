// Private to image_io.cpp: the ITK side of image IO on plain arrays. ITK bundles Eigen 3.3 in its
// headers, which clashes with the system Eigen 3.4 of the rest of the project, so the ITK code is
// compiled in its own translation unit (itk_image_io.cpp) that never includes Eigen.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace vim::pipeline::itk_io {

struct RawImage {
  std::vector<long> size;  // voxels per axis (axis 0 fastest in data)
  std::vector<double> spacing;
  std::vector<double> origin;
  std::vector<double> direction;  // row-major dim × dim
  std::vector<float> data;
  bool double_voxels = false;  // the file stores doubles: a finite value beyond ±FLT_MAX reads as ±inf
  bool labels = false;         // write: integer labels, stored as 16-bit signed integers
};

// A file whose header has been read and checked (the ITK ImageIO that read it, kept for the voxels).
struct Header;
// Reads and checks the header (existence, format, dimension 2/3, scalar pixels, size, spacing,
// origin). Throws InputError naming the file.
std::shared_ptr<Header> read_header(const std::string& path);
int dimension(const Header& header);
// read_header + dimension.
int header_dimension(const std::string& path);
// The voxels of a file whose header was read, as float (the header is not parsed again by us; ITK's
// reader reads it once more with the same ImageIO). Throws InputError.
RawImage read(const Header& header, int dim);
// read_header, then read.
RawImage read(const std::string& path, int dim);
// For .nii/.nii.gz: throws InputError naming the file and field when a geometry number of the header
// (pixdim, quaternion, offsets, srow) is NaN, infinite or beyond 1e15 (nifti_header_check.cpp).
void check_nifti_header_numbers(const std::string& path);
// Writes through a temporary name that keeps the extension, then renames.
void write(const RawImage& image, const std::string& path);

}  // namespace vim::pipeline::itk_io

// A label image from an uncompressed little-endian NIfTI-1 file (.nii; what `vim-make-phantom
// prostate X.mha --labels L.nii` writes): dimensions, voxel size and integer voxels (uint8, int8,
// int16, uint16, int32, uint32). The world orientation is not read: the image's first voxel centre
// is put at spacing/2, which is all a comparison of two meshers on the same voxels needs.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/image.hpp>

namespace vim::cgal_bench {

template <class T>
T header_field(const char* header, std::size_t offset) {
  T v;
  std::memcpy(&v, header + offset, sizeof(T));
  return v;
}

inline vim::Image<3> read_nifti_labels(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(path + ": cannot open");
  char h[348];
  if (!in.read(h, sizeof h) || header_field<std::int32_t>(h, 0) != 348)
    throw std::invalid_argument(path +
                                ": not an uncompressed little-endian NIfTI-1 file (sizeof_hdr != 348)");
  const auto ndim = header_field<std::int16_t>(h, 40);
  if (ndim < 3 || (ndim > 3 && header_field<std::int16_t>(h, 48) > 1))
    throw std::invalid_argument(path + ": dim[0] = " + std::to_string(ndim) + ": a 3D image is needed");
  std::array<long, 3> size{};
  std::array<double, 3> spacing{}, origin{};
  for (int a = 0; a < 3; ++a) {
    size[a] = header_field<std::int16_t>(h, 42 + 2 * a);
    spacing[a] = header_field<float>(h, 80 + 4 * a);
    if (size[a] < 2 || !(spacing[a] > 0.0))
      throw std::invalid_argument(path + ": axis " + std::to_string(a) + " has " + std::to_string(size[a]) +
                                  " voxels of size " + std::to_string(spacing[a]) +
                                  " (>= 2 voxels of size > 0 needed)");
    origin[a] = 0.5 * spacing[a];
  }
  const auto datatype = header_field<std::int16_t>(h, 70);
  const float slope = header_field<float>(h, 112), inter = header_field<float>(h, 116);
  if (slope != 0.0f && (slope != 1.0f || inter != 0.0f))
    throw std::invalid_argument(path + ": scl_slope/scl_inter rescale the voxels: integer labels are needed");
  vim::Image<3> image(size, spacing, origin);
  in.seekg(static_cast<std::streamoff>(header_field<float>(h, 108)));
  auto read_as = [&](auto zero) {
    std::vector<decltype(zero)> raw(image.voxel_count());
    if (!in.read(reinterpret_cast<char*>(raw.data()),
                 static_cast<std::streamsize>(raw.size() * sizeof(zero))))
      throw std::invalid_argument(path + ": file ends before its " + std::to_string(raw.size()) + " voxels");
    for (std::size_t k = 0; k < raw.size(); ++k) image.data[k] = static_cast<float>(raw[k]);
  };
  switch (datatype) {
    case 2:
      read_as(std::uint8_t{});
      break;
    case 256:
      read_as(std::int8_t{});
      break;
    case 4:
      read_as(std::int16_t{});
      break;
    case 512:
      read_as(std::uint16_t{});
      break;
    case 8:
      read_as(std::int32_t{});
      break;
    case 768:
      read_as(std::uint32_t{});
      break;
    default:
      throw std::invalid_argument(path + ": datatype " + std::to_string(datatype) +
                                  " (valid: 2, 4, 8, 256, 512, 768: integer voxels)");
  }
  return image;
}

inline vim::Image<3> read_inr_labels(const std::string& path) {
  CGAL::Image_3 in;
  if (!in.read(path)) throw std::invalid_argument(path + ": cannot read as an INRIMAGE (.inr, .inr.gz)");
  const std::array<long, 3> size{static_cast<long>(in.xdim()), static_cast<long>(in.ydim()),
                                 static_cast<long>(in.zdim())};
  const std::array<double, 3> spacing{in.vx(), in.vy(), in.vz()};
  vim::Image<3> image(size, spacing, {0.5 * spacing[0], 0.5 * spacing[1], 0.5 * spacing[2]});
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const auto i = image.index_of(k);
    image.data[k] = in.value(static_cast<std::size_t>(i[0]), static_cast<std::size_t>(i[1]),
                             static_cast<std::size_t>(i[2]));
  }
  return image;
}

// Every stride-th voxel along each axis (stride 1: the image itself), labels renumbered 1..k by
// ascending value; throws std::invalid_argument for a non-integer voxel or more than 255 labels.
inline vim::Image<3> label_image(const std::string& path, long stride) {
  const bool inr = path.size() > 4 &&
                   (path.substr(path.size() - 4) == ".inr" || path.find(".inr.gz") != std::string::npos);
  const vim::Image<3> full = inr ? read_inr_labels(path) : read_nifti_labels(path);
  std::array<long, 3> size{};
  std::array<double, 3> spacing{};
  for (int a = 0; a < 3; ++a)
    size[a] = (full.size[a] + stride - 1) / stride, spacing[a] = full.spacing[a] * stride;
  vim::Image<3> image(size, spacing, {0.5 * spacing[0], 0.5 * spacing[1], 0.5 * spacing[2]});
  std::map<float, int> rank;
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    auto i = image.index_of(k);
    for (auto& c : i) c *= stride;
    const float v = full.at(i);
    if (v != std::round(v))
      throw std::invalid_argument(path + ": voxel " + std::to_string(k) + " holds " + std::to_string(v) +
                                  " (valid: integer labels)");
    image.data[k] = v;
    rank.emplace(v, 0);
  }
  if (rank.size() > 255)
    throw std::invalid_argument(path + ": " + std::to_string(rank.size()) + " labels (valid: at most 255)");
  int next = 1;
  for (auto& kv : rank) kv.second = next++;
  for (float& v : image.data) v = static_cast<float>(rank.at(v));
  return image;
}

}  // namespace vim::cgal_bench

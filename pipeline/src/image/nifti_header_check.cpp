// The numbers of a NIfTI-1/2 header that ITK 5.2 turns into the image geometry, checked before ITK
// reads the header: a NaN or infinite pixdim, quaternion, offset or srow value makes
// NiftiImageIO::ReadImageInformation abort the process (vnl_svd asserts a finite matrix; found by
// fuzz_nifti_header). Finite values beyond 1e15 are refused too: squared or multiplied they overflow.
// The header size field must be 348 or 540 as well.
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vim/pipeline/common/input_error.hpp>

#include "image/itk_image_io.hpp"

namespace vim::pipeline::itk_io {

namespace {

struct Field {
  const char* name;
  int offset;  // byte offset of the first value
  int count;   // values
};

// NIfTI-1 (float fields) and NIfTI-2 (double fields): pixdim, quatern_b..d, qoffset_x..z, srow_x..z.
constexpr Field kNifti1[] = {{"pixdim", 76, 8},  {"quatern_b/c/d", 256, 3}, {"qoffset_x/y/z", 268, 3},
                             {"srow_x", 280, 4}, {"srow_y", 296, 4},        {"srow_z", 312, 4}};
constexpr Field kNifti2[] = {{"pixdim", 104, 8}, {"quatern_b/c/d", 352, 3}, {"qoffset_x/y/z", 376, 3},
                             {"srow_x", 400, 4}, {"srow_y", 432, 4},        {"srow_z", 464, 4}};

template <typename Real, typename Bits>
double value_at(const unsigned char* h, int offset, bool swapped) {
  Bits bits = 0;
  std::memcpy(&bits, h + offset, sizeof bits);
  if (swapped)
    bits = sizeof bits == 4 ? static_cast<Bits>(__builtin_bswap32(static_cast<std::uint32_t>(bits)))
                            : static_cast<Bits>(__builtin_bswap64(static_cast<std::uint64_t>(bits)));
  Real v = 0;
  std::memcpy(&v, &bits, sizeof v);
  return static_cast<double>(v);
}

}  // namespace

void check_nifti_header_numbers(const std::string& path) {
  auto ends = [&](const char* tail) {
    const std::size_t n = std::strlen(tail);
    return path.size() >= n && path.compare(path.size() - n, n, tail) == 0;
  };
  if (!ends(".nii") && !ends(".nii.gz")) return;
  gzFile f = gzopen(path.c_str(), "rb");  // reads uncompressed files as they are
  if (!f) return;
  unsigned char h[540] = {};
  const int got = gzread(f, h, sizeof h);
  gzclose(f);
  std::int32_t size = 0;
  std::memcpy(&size, h, 4);
  const std::int32_t raw = size;
  const bool swapped = size != 348 && size != 540;
  if (swapped) size = static_cast<std::int32_t>(__builtin_bswap32(static_cast<std::uint32_t>(size)));
  // ITK's niftilib accepts any sizeof_hdr when the magic matches, and then the data-size check cannot
  // tell the layout: a 472-byte file declaring 5e8 voxels was read into 15 GB (fuzz_nifti_header).
  if (got >= 4 && size != 348 && size != 540)
    throw InputError(path + ": NIfTI header starts with sizeof_hdr = " + std::to_string(raw) +
                     "; valid: 348 (NIfTI-1) or 540 (NIfTI-2), in either byte order");
  if (got < 4) return;  // too short to be NIfTI; ITK decides
  // A header cut short: ITK 5.2 reads the missing bytes as geometry (a 483-byte file declaring a
  // 540-byte NIfTI-2 header aborted the process in vnl_svd; fuzz_nifti_header).
  if (got < size)
    throw InputError(path + ": NIfTI header is truncated: the file holds " + std::to_string(got) +
                     " bytes, its sizeof_hdr declares a " + std::to_string(size) + "-byte NIfTI-" +
                     (size == 348 ? "1" : "2") + " header");
  const bool one = size == 348;
  for (const Field& field : one ? kNifti1 : kNifti2)
    for (int i = 0; i < field.count; ++i) {
      const double v = one ? value_at<float, std::uint32_t>(h, field.offset + 4 * i, swapped)
                           : value_at<double, std::uint64_t>(h, field.offset + 8 * i, swapped);
      // Denormal values (below the smallest normal float or double) reach ITK's direction matrix as
      // divisions by almost zero and abort it like NaN does (fuzz_nifti_header).
      const double smallest = one ? std::numeric_limits<float>::min() : std::numeric_limits<double>::min();
      if (std::abs(v) < 1e15 && (v == 0.0 || std::abs(v) >= smallest)) continue;  // false for NaN
      std::ostringstream m;
      m << path << ": NIfTI header field " << field.name << " (value " << i + 1 << ") = " << v
        << " is not a usable number (valid: 0, or finite with a magnitude from " << smallest
        << " (no denormals) to below 1e15)";
      throw InputError(m.str());
    }
}

}  // namespace vim::pipeline::itk_io

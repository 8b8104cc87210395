// libFuzzer target for the NIfTI-1 path (image_io.hpp): the bytes are a .nii file (348-byte binary
// header, extensions, voxels), read as in image_file_harness.hpp. Built by scripts/fuzz.sh
// (fuzz/CMakeLists.txt); seeds in fuzz/corpus/nifti/.
#include "image_file_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  vim::fuzz::read_image_file(data, size, ".nii");
  return 0;
}

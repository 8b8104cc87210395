// libFuzzer target for the MetaImage and NRRD header paths (image_io.hpp): the first byte chooses
// .nrrd (odd) or .mha (even), the rest is the file (image_file_harness.hpp). Built by scripts/fuzz.sh
// (fuzz/CMakeLists.txt).
#include "image_file_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  vim::fuzz::read_image_file(data + 1, size - 1, (data[0] & 1) ? ".nrrd" : ".mha");
  return 0;
}

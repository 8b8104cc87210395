// libFuzzer target for the image-header path (image_io.hpp): bytes are written to a temporary
// .mha or .nrrd file (first byte chooses) and read through vim::pipeline::image_dimension and
// read_image<dim>. A bad file must throw InputError; a crash, any other exception or a sanitizer
// report is a bug. Built by scripts/fuzz.sh (fuzz/CMakeLists.txt).
#include <vim/pipeline/image_io.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace {

std::string temp_name(const char* ext) {
  static const std::string dir = [] {
    const std::string d = (std::filesystem::temp_directory_path() / ("vim_fuzz_img_" + std::to_string(::getpid()))).string();
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir + "/input" + ext;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const char* ext = (data[0] & 1) ? ".nrrd" : ".mha";
  const std::string path = temp_name(ext);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  try {
    const int d = vim::pipeline::image_dimension(path);
    if (d == 2) (void)vim::pipeline::read_image<2>(path);
    else if (d == 3) (void)vim::pipeline::read_image<3>(path);
    else __builtin_trap();  // image_dimension promises 2 or 3
  } catch (const vim::pipeline::InputError& e) {
    if (std::string(e.what()).find(path) == std::string::npos) __builtin_trap();  // message names the file
  }
  std::remove(path.c_str());
  return 0;
}

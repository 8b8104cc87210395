// The body shared by the image-reader fuzz targets: bytes written to a temporary file with the given
// extension and read through vim::pipeline::image_dimension and read_image<dim>. A bad file must
// throw InputError naming the file; a crash, any other exception or a sanitizer report is a bug.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vim/pipeline/image/image_io.hpp>

namespace vim::fuzz {

inline std::string temp_name(const char* ext) {
  static const std::string dir = [] {
    const std::string d =
        (std::filesystem::temp_directory_path() / ("vim_fuzz_img_" + std::to_string(::getpid()))).string();
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir + "/input" + ext;
}

inline void read_image_file(const std::uint8_t* data, std::size_t size, const char* ext) {
  const std::string path = temp_name(ext);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const int d = vim::pipeline::image_dimension(path);
    if (d == 2)
      (void)vim::pipeline::read_image<2>(path);
    else if (d == 3)
      (void)vim::pipeline::read_image<3>(path);
    else
      __builtin_trap();  // image_dimension promises 2 or 3
  } catch (const vim::pipeline::InputError& e) {
    if (std::string(e.what()).find(path) == std::string::npos) __builtin_trap();  // message names the file
  }
  std::remove(path.c_str());
}

}  // namespace vim::fuzz

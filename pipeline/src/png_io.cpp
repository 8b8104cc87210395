// 8-bit RGB PNG for the figure canvas (png.hpp): written with zlib, read through ITK's PNGImageIO (so
// the tests read the files with an independent decoder). Kept free of the system Eigen: ITK's bundled
// Eigen must not meet it in one translation unit.
#include <vim/pipeline/atomic_file.hpp>

#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>

#include <zlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <stdexcept>
#include <vector>

namespace vim::pipeline {

using RgbImage = itk::Image<itk::RGBPixel<unsigned char>, 2>;

namespace {

void put_u32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((v >> shift) & 0xFF));
}

void put_chunk(std::string& out, const char* type, const std::string& data) {
  put_u32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t at = out.size();
  out.append(type, 4);
  out += data;
  const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(out.data() + at), static_cast<uInt>(4 + data.size()));
  put_u32(out, static_cast<std::uint32_t>(crc));
}

}  // namespace

// Encoded here with zlib (8-bit RGB, no filter, one IDAT) and written with a checked stream: ITK's
// PNG writer aborted the process (heap corruption in libpng's error path) when the disk was full.
void write_rgb_png(const std::filesystem::path& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width <= 0 || height <= 0 || rgb.size() != static_cast<std::size_t>(width) * height * 3)
    throw std::invalid_argument("write_rgb_png: " + path.string() + ": the pixel buffer does not match " +
                                std::to_string(width) + " x " + std::to_string(height) + " RGB");
  std::string raw;
  raw.reserve(static_cast<std::size_t>(height) * (3 * width + 1));
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');  // filter type 0 (none)
    raw.append(reinterpret_cast<const char*>(rgb.data()) + static_cast<std::size_t>(y) * width * 3,
               static_cast<std::size_t>(width) * 3);
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error("cannot write " + path.string() + ": zlib compression failed");
  packed.resize(packed_size);
  std::string header;
  put_u32(header, static_cast<std::uint32_t>(width));
  put_u32(header, static_cast<std::uint32_t>(height));
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, adaptive filtering, no interlace
  std::string file("\x89PNG\r\n\x1a\n", 8);
  put_chunk(file, "IHDR", header);
  put_chunk(file, "IDAT", packed);
  put_chunk(file, "IEND", std::string());
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot open " + tmp.string() + " for writing");
    out.write(file.data(), static_cast<std::streamsize>(file.size()));
    out.close();
    if (!out) throw std::runtime_error("error while writing " + path.string() + " (is the disk full?)");
  });
}

std::vector<std::uint8_t> read_rgb_png(const std::filesystem::path& path, int& width, int& height) {
  auto reader = itk::ImageFileReader<RgbImage>::New();
  reader->SetImageIO(itk::PNGImageIO::New());
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error("cannot read " + path.string() + ": " + e.GetDescription());
  }
  const auto image = reader->GetOutput();
  const auto size = image->GetLargestPossibleRegion().GetSize();
  width = static_cast<int>(size[0]);
  height = static_cast<int>(size[1]);
  std::vector<std::uint8_t> rgb;
  rgb.reserve(static_cast<std::size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const auto p = image->GetPixel({{x, y}});
      rgb.insert(rgb.end(), {p.GetRed(), p.GetGreen(), p.GetBlue()});
    }
  return rgb;
}

}  // namespace vim::pipeline

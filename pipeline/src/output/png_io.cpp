// PNG files of the figure canvas (png.hpp): encoded by Cairo (8-bit RGB) into memory and written
// with a checked stream under a temporary name; read back through ITK's PNGImageIO (so the tests
// decode the files independently of the encoder). Kept free of png.hpp: ITK's bundled Eigen must not
// meet the system Eigen in one translation unit.
#include <cairo.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/pipeline/common/atomic_file.hpp>

namespace vim::pipeline {

namespace {

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

}  // namespace

// Encodes width × height Cairo RGB24 pixels (row-major, no padding) and writes them to `path`.
void write_rgb24_png(const std::filesystem::path& path, int width, int height, const std::uint32_t* pixels) {
  // Cairo only reads the pixels here.
  auto* data = reinterpret_cast<unsigned char*>(const_cast<std::uint32_t*>(pixels));
  cairo_surface_t* surface =
      cairo_image_surface_create_for_data(data, CAIRO_FORMAT_RGB24, width, height, 4 * width);
  std::string file;
  const cairo_status_t status = cairo_surface_write_to_png_stream(surface, append_bytes, &file);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error("cannot write " + path.string() + ": PNG encoding failed (" +
                             cairo_status_to_string(status) + ")");
  // Written with a checked stream: a full disk gives a clear error and no file under the final name.
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot open " + tmp.string() + " for writing");
    errno = 0;
    out.write(file.data(), static_cast<std::streamsize>(file.size()));
    out.close();
    if (!out) {
      // errno of the failed write() (EFBIG, ENOSPC, EIO, ...), as the text and VTK writers report it.
      const std::string why = errno != 0 ? std::string(": ") + std::strerror(errno) : std::string();
      throw std::runtime_error("cannot write " + path.string() + why + " (is the disk full?)");
    }
  });
}

// Decodes an 8-bit RGB (or grey/RGBA, converted by ITK) PNG into r, g, b bytes per pixel.
std::vector<std::uint8_t> read_rgb_png(const std::filesystem::path& path, int& width, int& height) {
  using RgbImage = itk::Image<itk::RGBPixel<unsigned char>, 2>;
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

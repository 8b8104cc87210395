// 8-bit RGB PNG read/write through ITK's PNGImageIO for the figure canvas (png.hpp). Kept free of
// the system Eigen: ITK's bundled Eigen must not meet it in one translation unit.
#include <vim/pipeline/atomic_file.hpp>

#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace vim::pipeline {

using RgbImage = itk::Image<itk::RGBPixel<unsigned char>, 2>;

void write_rgb_png(const std::filesystem::path& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
  auto image = RgbImage::New();
  RgbImage::RegionType region;
  region.SetSize({{static_cast<itk::SizeValueType>(width), static_cast<itk::SizeValueType>(height)}});
  image->SetRegions(region);
  image->Allocate();
  std::size_t k = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x, k += 3) {
      itk::RGBPixel<unsigned char> p;
      p.Set(rgb[k], rgb[k + 1], rgb[k + 2]);
      image->SetPixel({{x, y}}, p);
    }
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    // The temporary keeps a .png extension while ITK writes it, then becomes write_atomically's name.
    const std::filesystem::path tmp_png = tmp.string() + ".png";
    try {
      auto writer = itk::ImageFileWriter<RgbImage>::New();
      writer->SetImageIO(itk::PNGImageIO::New());
      writer->SetFileName(tmp_png.string());
      writer->SetInput(image);
      writer->Update();
    } catch (const itk::ExceptionObject& e) {
      std::error_code ec;
      std::filesystem::remove(tmp_png, ec);
      throw std::runtime_error("cannot write " + path.string() + ": " + e.GetDescription());
    }
    std::filesystem::rename(tmp_png, tmp);
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

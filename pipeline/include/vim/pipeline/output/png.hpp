// An RGB raster canvas for the figures (no display), drawn with Cairo: anti-aliased lines and filled
// polygons in continuous pixel coordinates, rectangles, text in a real font (DejaVu Sans through
// Cairo's font API), a viridis-like colormap and grey ramp, and PNG output (Cairo's encoder) under a
// temporary name (write_atomically). The pixels live here, in Cairo's RGB24 layout, so single pixels
// can be set and read directly.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

struct _cairo;  // cairo_t (cairo.h), kept out of this header

namespace vim::pipeline {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb& o) const { return r == o.r && g == o.g && b == o.b; }
  bool operator!=(const Rgb& o) const { return !(*this == o); }
};

namespace colors {
inline constexpr Rgb white{255, 255, 255};
inline constexpr Rgb black{0, 0, 0};
inline constexpr Rgb outline{255, 0, 0};  // element outlines over the grey image
inline constexpr Rgb axis{40, 40, 40};
inline constexpr Rgb light_grey{200, 200, 200};
}  // namespace colors

// Viridis-like map of t ∈ [0,1] (clamped); never pure black, never grey (r == g == b).
Rgb viridis(double t);
// Grey ramp of t ∈ [0,1] (clamped): r = g = b.
Rgb grey(double t);
// Distinct line colours for plot series (cycled).
Rgb series_color(int k);

class Canvas {
 public:
  Canvas(int width, int height, Rgb background = colors::white);
  int width() const { return width_; }
  int height() const { return height_; }

  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }
  void set(int x, int y, Rgb c) {
    if (inside(x, y)) pixels_[static_cast<std::size_t>(y) * width_ + x] = pack(c);
  }
  Rgb at(int x, int y) const {
    const std::uint32_t p = pixels_[static_cast<std::size_t>(y) * width_ + x];
    return {static_cast<std::uint8_t>(p >> 16), static_cast<std::uint8_t>(p >> 8),
            static_cast<std::uint8_t>(p)};
  }

  // Coordinates are continuous: pixel (i, j) covers [i, i+1) × [j, j+1), so a line through pixel
  // centres at integer i lies at i + 0.5.
  // Anti-aliased straight line of `thickness` pixels with round caps (a zero-length line is a dot).
  void line(double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
  // Closed outline of a polygon.
  void polyline_closed(const std::vector<Eigen::Vector2d>& pts, Rgb c, int thickness = 1);
  // Anti-aliased fill of a polygon (even-odd rule): pixels wholly inside get exactly `c`.
  void fill_polygon(const std::vector<Eigen::Vector2d>& pts, Rgb c);
  void fill_rect(int x0, int y0, int x1, int y1, Rgb c);  // whole pixels, inclusive corners

  // Text of `size` pixels (font size; the box is about 1.2·size high), blended over the canvas with
  // the font's coverage, its bounding box placed at (x, y) by `h` (start = box's left edge at x) and
  // `v` (start = box's top edge at y). `vertical` turns it 90° counter-clockwise (reads bottom to
  // top; the alignments then apply to the turned box; the same coverage, turned pixel by pixel).
  // Returns the box {left, top, width, height} ({x, y, 0, 0} for an empty string).
  enum class Align { start, centre, end };
  std::array<int, 4> text(int x, int y, const std::string& s, Rgb c, int size = 12, Align h = Align::start,
                          Align v = Align::start, bool vertical = false);
  // Width and height of text()'s box for `s` (unturned), without drawing; {0, 0} for an empty string.
  static std::array<int, 2> text_size(const std::string& s, int size = 12);

  // Writes an 8-bit RGB PNG (Cairo's encoder) via a temporary name + rename; throws
  // std::runtime_error naming the file if it cannot be written.
  void write_png(const std::filesystem::path& path) const;

  // Reads an RGB PNG back through ITK's PNG reader (an independent decoder, for tests and tools
  // that post-process figures).
  static Canvas read_png(const std::filesystem::path& path);

 private:
  static std::uint32_t pack(Rgb c) {
    return 0xFF000000u | (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
  }
  // Runs `paint` on a Cairo context over the pixels (flushed back before returning).
  void paint(const std::function<void(_cairo*)>& draw);

  int width_, height_;
  std::vector<std::uint32_t> pixels_;  // row-major, Cairo RGB24 (0xXXRRGGBB, native endian)
};

}  // namespace vim::pipeline

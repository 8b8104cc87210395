// Canvas drawing through Cairo (see png.hpp): lines, polygons and rectangles on an RGB24 image
// surface over the canvas's own pixels. Text is in png_text.cpp, PNG encoding and decoding in png_io.cpp.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vim/pipeline/output/png.hpp>

namespace vim::pipeline {

// png_io.cpp
void write_rgb24_png(const std::filesystem::path& path, int width, int height, const std::uint32_t* pixels);
std::vector<std::uint8_t> read_rgb_png(const std::filesystem::path& path, int& width, int& height);

namespace {

std::uint8_t lerp8(double a, double b, double t) {
  return static_cast<std::uint8_t>(std::lround(a + (b - a) * t));
}

void set_source(cairo_t* cr, Rgb c) { cairo_set_source_rgb(cr, c.r / 255.0, c.g / 255.0, c.b / 255.0); }

// Degenerate input (non-finite or absurdly far points) draws nothing.
bool drawable(double v) { return std::isfinite(v) && std::abs(v) <= 1e5; }

}  // namespace

Rgb viridis(double t) {
  // Matplotlib's viridis sampled at nine points, linearly interpolated.
  static const double table[9][3] = {{68, 1, 84},    {71, 44, 122},  {59, 81, 139},
                                     {44, 113, 142}, {33, 144, 141}, {39, 173, 129},
                                     {92, 200, 99},  {170, 220, 50}, {253, 231, 37}};
  if (!std::isfinite(t)) t = 0.0;
  t = std::clamp(t, 0.0, 1.0) * 8.0;
  const int i = std::min(7, static_cast<int>(std::floor(t)));
  const double f = t - i;
  return {lerp8(table[i][0], table[i + 1][0], f), lerp8(table[i][1], table[i + 1][1], f),
          lerp8(table[i][2], table[i + 1][2], f)};
}

Rgb grey(double t) {
  if (!std::isfinite(t)) t = 0.0;
  const auto g = static_cast<std::uint8_t>(std::lround(std::clamp(t, 0.0, 1.0) * 255.0));
  return {g, g, g};
}

Rgb series_color(int k) {
  static const Rgb palette[] = {
      {31, 119, 180}, {214, 39, 40}, {44, 160, 44}, {255, 127, 14}, {148, 103, 189}};
  return palette[static_cast<std::size_t>(k) % 5];
}

Canvas::Canvas(int width, int height, Rgb background) : width_(width), height_(height) {
  if (width <= 0 || height <= 0 || width > 32767 || height > 32767)
    throw std::invalid_argument("canvas size must be in [1, 32767] pixels, not " + std::to_string(width) +
                                " x " + std::to_string(height));
  pixels_.assign(static_cast<std::size_t>(width) * height, pack(background));
}

void Canvas::paint(const std::function<void(cairo_t*)>& draw) {
  // RGB24 rows are 4 bytes per pixel with no padding, so the pixel vector is the surface's memory.
  const int stride = cairo_format_stride_for_width(CAIRO_FORMAT_RGB24, width_);
  if (stride != 4 * width_) throw std::logic_error("Canvas: unexpected Cairo RGB24 stride");
  cairo_surface_t* surface = cairo_image_surface_create_for_data(
      reinterpret_cast<unsigned char*>(pixels_.data()), CAIRO_FORMAT_RGB24, width_, height_, stride);
  cairo_t* cr = cairo_create(surface);
  cairo_set_antialias(cr, CAIRO_ANTIALIAS_GRAY);
  draw(cr);
  const cairo_status_t status = cairo_status(cr);
  cairo_destroy(cr);
  cairo_surface_flush(surface);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string("Cairo: ") + cairo_status_to_string(status));
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  for (double q : {x0, y0, x1, y1})
    if (!drawable(q)) return;
  paint([&](cairo_t* cr) {
    set_source(cr, c);
    cairo_set_line_width(cr, std::max(1, thickness));
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1, y1);
    cairo_stroke(cr);
  });
}

void Canvas::polyline_closed(const std::vector<Eigen::Vector2d>& pts, Rgb c, int thickness) {
  if (pts.empty()) return;
  for (const auto& p : pts)
    if (!drawable(p.x()) || !drawable(p.y())) return;
  paint([&](cairo_t* cr) {
    set_source(cr, c);
    cairo_set_line_width(cr, std::max(1, thickness));
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    cairo_move_to(cr, pts[0].x(), pts[0].y());
    for (std::size_t k = 1; k < pts.size(); ++k) cairo_line_to(cr, pts[k].x(), pts[k].y());
    if (pts.size() > 2)
      cairo_close_path(cr);
    else if (pts.size() == 1)
      cairo_line_to(cr, pts[0].x(), pts[0].y());  // a dot
    cairo_stroke(cr);
  });
}

void Canvas::fill_polygon(const std::vector<Eigen::Vector2d>& pts, Rgb c) {
  if (pts.size() < 3) return;
  for (const auto& p : pts)
    if (!drawable(p.x()) || !drawable(p.y())) return;
  paint([&](cairo_t* cr) {
    set_source(cr, c);
    cairo_set_fill_rule(cr, CAIRO_FILL_RULE_EVEN_ODD);
    cairo_move_to(cr, pts[0].x(), pts[0].y());
    for (std::size_t k = 1; k < pts.size(); ++k) cairo_line_to(cr, pts[k].x(), pts[k].y());
    cairo_close_path(cr);
    cairo_fill(cr);
  });
}

void Canvas::fill_rect(int x0, int y0, int x1, int y1, Rgb c) {
  const int left = std::min(x0, x1), top = std::min(y0, y1);
  paint([&](cairo_t* cr) {
    set_source(cr, c);
    cairo_rectangle(cr, left, top, std::abs(x1 - x0) + 1, std::abs(y1 - y0) + 1);
    cairo_fill(cr);
  });
}

void Canvas::write_png(const std::filesystem::path& path) const {
  write_rgb24_png(path, width_, height_, pixels_.data());
}

Canvas Canvas::read_png(const std::filesystem::path& path) {
  int w = 0, h = 0;
  const std::vector<std::uint8_t> rgb = read_rgb_png(path, w, h);
  Canvas c(w, h);
  for (std::size_t k = 0; k < c.pixels_.size(); ++k)
    c.pixels_[k] = pack({rgb[3 * k], rgb[3 * k + 1], rgb[3 * k + 2]});
  return c;
}

}  // namespace vim::pipeline

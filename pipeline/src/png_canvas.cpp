// Raster canvas and PNG output for the figures (see png.hpp).
// The ITK PNG IO lives in png_io.cpp: ITK's bundled Eigen (itkeigen) must not share a TU with
// the system Eigen that png.hpp uses.
#include <vim/pipeline/png.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vim::pipeline {

// png_io.cpp
void write_rgb_png(const std::filesystem::path& path, int width, int height, const std::vector<std::uint8_t>& rgb);
std::vector<std::uint8_t> read_rgb_png(const std::filesystem::path& path, int& width, int& height);

namespace {

std::uint8_t lerp8(double a, double b, double t) {
  return static_cast<std::uint8_t>(std::lround(a + (b - a) * t));
}

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
  static const Rgb palette[] = {{31, 119, 180}, {214, 39, 40}, {44, 160, 44}, {255, 127, 14}, {148, 103, 189}};
  return palette[static_cast<std::size_t>(k) % 5];
}

Canvas::Canvas(int width, int height, Rgb background) : width_(width), height_(height) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("canvas size must be positive");
  pixels_.assign(static_cast<std::size_t>(width) * height, background);
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  // Non-finite or absurdly far endpoints (degenerate input) draw nothing rather than loop for ages.
  for (double q : {x0, y0, x1, y1})
    if (!std::isfinite(q) || std::abs(q) > 1e5) return;
  // Endpoints are the pixels that contain them, so a point on the line always lands on its pixel.
  long ax = static_cast<long>(std::floor(x0)), ay = static_cast<long>(std::floor(y0));
  const long bx = static_cast<long>(std::floor(x1)), by = static_cast<long>(std::floor(y1));
  const long dx = std::labs(bx - ax), dy = -std::labs(by - ay);
  const long sx = ax < bx ? 1 : -1, sy = ay < by ? 1 : -1;
  long err = dx + dy;
  const int lo = -(thickness - 1) / 2, hi = thickness / 2;
  for (long steps = 0;; ++steps) {
    for (int oy = lo; oy <= hi; ++oy)
      for (int ox = lo; ox <= hi; ++ox)
        set(static_cast<int>(ax + ox), static_cast<int>(ay + oy), c);
    if ((ax == bx && ay == by) || steps > dx - dy) break;
    const long e2 = 2 * err;
    if (e2 >= dy) { err += dy; ax += sx; }
    if (e2 <= dx) { err += dx; ay += sy; }
  }
}

void Canvas::polyline_closed(const std::vector<Eigen::Vector2d>& pts, Rgb c, int thickness) {
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const auto& a = pts[k];
    const auto& b = pts[(k + 1) % pts.size()];
    line(a.x(), a.y(), b.x(), b.y(), c, thickness);
  }
}

void Canvas::fill_polygon(const std::vector<Eigen::Vector2d>& pts, Rgb c) {
  if (pts.size() < 3) return;
  double ymin = pts[0].y(), ymax = pts[0].y();
  for (const auto& p : pts) {
    if (!p.allFinite()) return;
    ymin = std::min(ymin, p.y());
    ymax = std::max(ymax, p.y());
  }
  const int y0 = std::max(0, static_cast<int>(std::floor(ymin)));
  const int y1 = std::min(height_ - 1, static_cast<int>(std::ceil(ymax)));
  std::vector<double> xs;
  for (int y = y0; y <= y1; ++y) {
    const double yc = y + 0.5;
    xs.clear();
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const auto& a = pts[k];
      const auto& b = pts[(k + 1) % pts.size()];
      if ((a.y() <= yc) != (b.y() <= yc)) xs.push_back(a.x() + (yc - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
    }
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
      const int xa = std::max(0, static_cast<int>(std::ceil(xs[k] - 0.5)));
      const int xb = std::min(width_ - 1, static_cast<int>(std::ceil(xs[k + 1] - 0.5)) - 1);
      for (int x = xa; x <= xb; ++x) pixels_[static_cast<std::size_t>(y) * width_ + x] = c;
    }
  }
}

void Canvas::fill_rect(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, std::min(y0, y1)); y <= std::min(height_ - 1, std::max(y0, y1)); ++y)
    for (int x = std::max(0, std::min(x0, x1)); x <= std::min(width_ - 1, std::max(x0, x1)); ++x)
      pixels_[static_cast<std::size_t>(y) * width_ + x] = c;
}

void Canvas::write_png(const std::filesystem::path& path) const {
  std::vector<std::uint8_t> rgb;
  rgb.reserve(pixels_.size() * 3);
  for (const Rgb& c : pixels_) rgb.insert(rgb.end(), {c.r, c.g, c.b});
  write_rgb_png(path, width_, height_, rgb);
}

Canvas Canvas::read_png(const std::filesystem::path& path) {
  int w = 0, h = 0;
  const std::vector<std::uint8_t> rgb = read_rgb_png(path, w, h);
  Canvas c(w, h);
  for (std::size_t k = 0; k < c.pixels_.size(); ++k) c.pixels_[k] = {rgb[3 * k], rgb[3 * k + 1], rgb[3 * k + 2]};
  return c;
}

}  // namespace vim::pipeline

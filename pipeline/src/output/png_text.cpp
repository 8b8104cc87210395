// Canvas::text (png.hpp): a string rasterised by Cairo in DejaVu Sans (Debian fonts-dejavu-core,
// found through fontconfig; another sans-serif face if it is missing) into a coverage mask the size
// of its box, then blended over the canvas pixel by pixel, turned for vertical text. Rendering
// unturned and turning the mask keeps vertical text the same glyphs as horizontal text.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>
#include <vim/pipeline/output/png.hpp>

namespace vim::pipeline {

namespace {

constexpr const char* kFontFamily = "DejaVu Sans";

// A string's coverage (0–255) in a box of width × height pixels, row-major, top row first.
struct Mask {
  int width = 0, height = 0;
  std::vector<std::uint8_t> coverage;
};

using Surface = std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)>;
using Context = std::unique_ptr<cairo_t, decltype(&cairo_destroy)>;

void select_font(cairo_t* cr, int size) {
  cairo_select_font_face(cr, kFontFamily, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, std::max(1, size));
  cairo_font_options_t* options = cairo_font_options_create();
  cairo_font_options_set_antialias(options, CAIRO_ANTIALIAS_GRAY);
  cairo_font_options_set_hint_metrics(options, CAIRO_HINT_METRICS_ON);
  cairo_set_font_options(cr, options);
  cairo_font_options_destroy(options);
}

// The box: from the left of the first glyph's ink (or the pen start) to the end of the advance (or
// the last ink), from the font's ascent above the baseline to its descent below. `pen_x` is where
// the pen starts inside the box, `baseline` the baseline's distance from the top.
struct Layout {
  int width = 0, height = 0;
  double pen_x = 0.0, baseline = 0.0;
};

Layout layout(cairo_t* cr, const std::string& s) {
  cairo_text_extents_t te;
  cairo_font_extents_t fe;
  cairo_text_extents(cr, s.c_str(), &te);
  cairo_font_extents(cr, &fe);
  Layout l;
  l.pen_x = std::ceil(std::max(0.0, -te.x_bearing));
  l.baseline = std::ceil(fe.ascent);
  l.width = static_cast<int>(std::ceil(l.pen_x + std::max(te.x_advance, te.x_bearing + te.width)));
  l.height = static_cast<int>(l.baseline + std::ceil(fe.descent));
  return l;
}

Mask render(const std::string& s, int size, bool draw) {
  Mask m;
  if (s.empty()) return m;
  Surface probe(cairo_image_surface_create(CAIRO_FORMAT_A8, 1, 1), cairo_surface_destroy);
  Context pc(cairo_create(probe.get()), cairo_destroy);
  select_font(pc.get(), size);
  const Layout l = layout(pc.get(), s);
  m.width = std::max(1, l.width);
  m.height = std::max(1, l.height);
  if (!draw) return m;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_A8, m.width, m.height), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  select_font(cr.get(), size);
  cairo_move_to(cr.get(), l.pen_x, l.baseline);
  cairo_show_text(cr.get(), s.c_str());
  cairo_surface_flush(surface.get());
  const unsigned char* data = cairo_image_surface_get_data(surface.get());
  const int stride = cairo_image_surface_get_stride(surface.get());
  m.coverage.resize(static_cast<std::size_t>(m.width) * m.height);
  for (int y = 0; y < m.height; ++y)
    std::copy(data + static_cast<std::size_t>(y) * stride,
              data + static_cast<std::size_t>(y) * stride + m.width,
              m.coverage.begin() + static_cast<std::ptrdiff_t>(y) * m.width);
  return m;
}

}  // namespace

std::array<int, 2> Canvas::text_size(const std::string& s, int size) {
  const Mask m = render(s, size, false);
  return {{m.width, m.height}};
}

std::array<int, 4> Canvas::text(int x, int y, const std::string& s, Rgb c, int size, Align h, Align v,
                                bool vertical) {
  const Mask m = render(s, size, true);
  if (m.coverage.empty()) return {{x, y, 0, 0}};
  const int bw = vertical ? m.height : m.width, bh = vertical ? m.width : m.height;
  auto place = [](int at, int length, Align a) {
    return a == Align::start ? at : a == Align::centre ? at - length / 2 : at - length;
  };
  const int left = place(x, bw, h), top = place(y, bh, v);
  for (int iy = 0; iy < m.height; ++iy)
    for (int ix = 0; ix < m.width; ++ix) {
      const int a = m.coverage[static_cast<std::size_t>(iy) * m.width + ix];
      if (a == 0) continue;
      // Vertical (turned counter-clockwise): the string's start at the bottom, its top on the left.
      const int px = vertical ? left + iy : left + ix;
      const int py = vertical ? top + (m.width - 1 - ix) : top + iy;
      if (!inside(px, py)) continue;
      const Rgb b = at(px, py);
      auto mix = [a](std::uint8_t fg, std::uint8_t bg) {
        return static_cast<std::uint8_t>((fg * a + bg * (255 - a) + 127) / 255);
      };
      set(px, py, {mix(c.r, b.r), mix(c.g, b.g), mix(c.b, b.b)});
    }
  return {{left, top, bw, bh}};
}

}  // namespace vim::pipeline

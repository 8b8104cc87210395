// Canvas::text (png.hpp): strings rasterised by VTK's FreeType tools with VTK's embedded Arial, so
// figures get labels without a display, an X server or font files on the machine. Kept out of
// png_canvas.cpp so only this file needs the VTK rendering headers.
#include <vim/pipeline/png.hpp>

#include <vtkFreeTypeTools.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkStdString.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace vim::pipeline {

namespace {

// The string rasterised by VTK: coverage in the alpha channel of `img`, the string occupying pixels
// [0, dims[0]) × [0, dims[1]) with y up. False for an empty string or a failed render.
bool render(const std::string& s, int size, vtkImageData* img, int dims[2]) {
  if (s.empty()) return false;
  vtkNew<vtkTextProperty> prop;
  prop->SetFontFamilyToArial();
  prop->SetFontSize(std::max(1, size));
  prop->SetColor(0.0, 0.0, 0.0);
  prop->SetJustificationToLeft();
  prop->SetVerticalJustificationToBottom();
  // vtkFreeTypeTools is a process-wide singleton with a glyph cache.
  static std::mutex m;
  std::lock_guard<std::mutex> lock(m);
  return vtkFreeTypeTools::GetInstance()->RenderString(prop, vtkStdString(s), 72, img, dims) && dims[0] > 0 &&
         dims[1] > 0 && img->GetNumberOfScalarComponents() == 4;
}

}  // namespace

std::array<int, 2> Canvas::text_size(const std::string& s, int size) {
  vtkNew<vtkImageData> img;
  int dims[2] = {0, 0};
  return render(s, size, img, dims) ? std::array<int, 2>{{dims[0], dims[1]}} : std::array<int, 2>{{0, 0}};
}

std::array<int, 4> Canvas::text(int x, int y, const std::string& s, Rgb c, int size, Align h, Align v, bool vertical) {
  vtkNew<vtkImageData> img;
  int dims[2] = {0, 0};
  if (!render(s, size, img, dims)) return {{x, y, 0, 0}};
  const int tw = dims[0], th = dims[1];
  const int* extent = img->GetDimensions();
  const auto* rgba = static_cast<const unsigned char*>(img->GetScalarPointer());
  const int bw = vertical ? th : tw, bh = vertical ? tw : th;
  auto place = [](int at, int length, Align a) {
    return a == Align::start ? at : a == Align::centre ? at - length / 2 : at - length;
  };
  const int left = place(x, bw, h), top = place(y, bh, v);
  for (int iy = 0; iy < th; ++iy)
    for (int ix = 0; ix < tw; ++ix) {
      const int a = rgba[4 * (static_cast<std::size_t>(iy) * extent[0] + ix) + 3];
      if (a == 0) continue;
      // Horizontal: column ix, row th − 1 − iy from the top. Vertical (turned counter-clockwise):
      // the string's start at the bottom, its top (iy = th − 1) on the left.
      const int px = vertical ? left + (th - 1 - iy) : left + ix;
      const int py = vertical ? top + (tw - 1 - ix) : top + (th - 1 - iy);
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

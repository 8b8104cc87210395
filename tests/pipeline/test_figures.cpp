// Figures (figures.hpp, png.hpp): the PNGs exist with the expected size, are not blank, and the
// drawn element outlines pass through the mesh's actual intersection with the slice plane (crossing
// points computed here from the tetrahedra, pixel mapping recomputed from the image box). Lines are
// anti-aliased: a pixel a line crosses carries the line's colour in proportion to the share of the
// pixel the line covers, and that share is what the outline checks measure (the files are decoded by
// ITK's PNG reader, not by the encoder).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/output/figures.hpp>

#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim;
using namespace vim::pipeline;

namespace {

using vim::test::ScratchDir;
ScratchDir figures_dir(const std::string& name) { return vim::test::scratch_dir("figures", name); }

// Variance of the pixels' brightness r + g + b: 0 for a blank image.
double brightness_variance(const Canvas& c) {
  double s = 0, s2 = 0;
  const double n = static_cast<double>(c.width()) * c.height();
  for (int y = 0; y < c.height(); ++y)
    for (int x = 0; x < c.width(); ++x) {
      const Rgb p = c.at(x, y);
      const double v = p.r + p.g + p.b;
      s += v;
      s2 += v * v;
    }
  return s2 / n - (s / n) * (s / n);
}

// Some pixel within `radius` of (x, y) has `colour`, each channel within `tolerance` of it.
bool near_colour(const Canvas& c, double x, double y, Rgb colour, int radius, int tolerance = 0) {
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) {
      const int px = static_cast<int>(std::floor(x)) + dx, py = static_cast<int>(std::floor(y)) + dy;
      if (!c.inside(px, py)) continue;
      const Rgb p = c.at(px, py);
      if (std::abs(p.r - colour.r) <= tolerance && std::abs(p.g - colour.g) <= tolerance &&
          std::abs(p.b - colour.b) <= tolerance)
        return true;
    }
  return false;
}

// Share of the red outline colour in a pixel drawn over the grey image (r = g = b underneath):
// a·(255, 0, 0) + (1 − a)·(v, v, v) has r − g = 255·a.
double red_share(Rgb p) { return (p.r - std::max(p.g, p.b)) / 255.0; }

// Share of black ink in pixel (x, y): (1 − a)·background with the background taken as the brightest
// pixel within 3 pixels (the fill colours around an outline; never darker than what lies under it).
double black_share(const Canvas& c, int x, int y) {
  int bright = 1;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx)
      if (c.inside(x + dx, y + dy)) {
        const Rgb q = c.at(x + dx, y + dy);
        bright = std::max({bright, int{q.r}, int{q.g}, int{q.b}});
      }
  const Rgb p = c.at(x, y);
  return 1.0 - std::max({p.r, p.g, p.b}) / static_cast<double>(bright);
}

// A line passes through the pixel that holds (x, y): that pixel carries some of its colour (at least
// the share of a disc of half the line width around a point on it), and a pixel next to it at least
// half (the pixel whose centre lies nearest the line).
template <class Share>
void expect_line_through(double x, double y, Share share, const std::string& what) {
  const int px = static_cast<int>(std::floor(x)), py = static_cast<int>(std::floor(y));
  double best = 0.0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) best = std::max(best, share(px + dx, py + dy));
  EXPECT_GT(share(px, py), 0.1) << what << " at pixel " << px << "," << py;
  EXPECT_GE(best, 0.5) << what << " near pixel " << px << "," << py;
}

template <int dim>
OrientedImage<dim> gradient_image(const std::array<long, dim>& size, const std::array<double, dim>& spacing) {
  OrientedImage<dim> im;
  std::array<double, dim> origin{};
  im.image = Image<dim>(size, spacing, origin);
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k) {
    const auto i = im.image.index_of(k);
    double v = 0;
    for (int a = 0; a < dim; ++a) v += (a + 1) * i[a];
    im.image.data[k] = static_cast<float>(v);
  }
  return im;
}

template <int dim>
MeshModel<dim> grid_model_over(const Image<dim>& image, const std::array<int, dim>& nodes) {
  MeshModel<dim> m;
  m.mesh = regular_grid_mesh<dim>(image.box_min(), image.box_max(), nodes);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    ElementValue v;
    v.mean = image.interpolate(centroid<dim>(cell_points(m.mesh, c)));
    v.voxels = 1;
    m.values.push_back(v);
  }
  return m;
}

// Crossing points of tetrahedron edges with x[axis] = s (edges strictly across the plane).
std::vector<Eigen::Vector3d> crossings(const std::array<Eigen::Vector3d, 4>& x, int axis, double s) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double di = x[i][axis] - s, dj = x[j][axis] - s;
      if (di * dj < 0) out.push_back(x[i] + di / (di - dj) * (x[j] - x[i]));
    }
  return out;
}

}  // namespace

TEST(Canvas, PrimitivesAndPngRoundTrip) {
  const auto dir = figures_dir("canvas");
  Canvas c(30, 20);
  c.fill_polygon({{2, 2}, {12, 2}, {12, 8}, {2, 8}}, {10, 20, 30});
  EXPECT_EQ(c.at(2, 2), (Rgb{10, 20, 30}));
  EXPECT_EQ(c.at(11, 7), (Rgb{10, 20, 30}));
  EXPECT_EQ(c.at(12, 7), colors::white);  // pixel centre 12.5 is outside
  EXPECT_EQ(c.at(1, 5), colors::white);
  c.line(0.2, 15.7, 29.9, 15.1, colors::black);
  // Anti-aliased: each pixel of a column takes black in proportion to the share of it inside the band
  // of width 1 around the line (its slope is 0.02, so the band is 1.0002 pixels high): coverage
  // computed here per row from the line's height at the column's centre; Cairo's sampled coverage
  // is within 16/255 of it. Rows 13 and 17 stay white.
  long partial = 0;
  for (int x = 1; x < 29; ++x) {
    const double yc = 15.7 + (15.1 - 15.7) * ((x + 0.5) - 0.2) / (29.9 - 0.2);
    for (int y = 14; y <= 16; ++y) {
      const double cover = std::clamp(std::min(yc + 0.5, y + 1.0) - std::max(yc - 0.5, double(y)), 0.0, 1.0);
      EXPECT_NEAR(c.at(x, y).r, 255.0 * (1.0 - cover), 16.0) << x << "," << y;
      partial += c.at(x, y).r > 0 && c.at(x, y).r < 255;
    }
    EXPECT_EQ(c.at(x, 13), colors::white) << x;
    EXPECT_EQ(c.at(x, 17), colors::white) << x;
  }
  EXPECT_GT(partial, 28);  // every column has a partly covered pixel
  c.write_png(dir / "c.png");
  const Canvas r = Canvas::read_png(dir / "c.png");
  ASSERT_EQ(r.width(), 30);
  ASSERT_EQ(r.height(), 20);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 30; ++x) ASSERT_EQ(r.at(x, y), c.at(x, y));
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().filename(), "c.png");
  EXPECT_NE(viridis(0.0), viridis(1.0));
  EXPECT_EQ(grey(1.0), colors::white);
}

// Pixels that differ from white inside and outside a box {left, top, width, height}.
std::pair<long, long> inked(const Canvas& c, const std::array<int, 4>& box) {
  long in = 0, out = 0;
  for (int y = 0; y < c.height(); ++y)
    for (int x = 0; x < c.width(); ++x) {
      if (c.at(x, y) == colors::white) continue;
      const bool inside = x >= box[0] && x < box[0] + box[2] && y >= box[1] && y < box[1] + box[3];
      (inside ? in : out) += 1;
    }
  return {in, out};
}

// Text lands inside the box it reports, placed by the alignments; a longer string is wider; the
// vertical box is the horizontal one turned; the strokes are dark (blended with the font's coverage).
TEST(Canvas, TextIsDrawnInsideItsAlignedBox) {
  Canvas a(200, 60);
  const auto box = a.text(10, 5, "depth 123 [mm]", colors::black, 14);
  EXPECT_EQ(box[0], 10);
  EXPECT_EQ(box[1], 5);
  EXPECT_GT(box[2], 60);
  EXPECT_GT(box[3], 10);
  EXPECT_LT(box[3], 30);
  const auto [in, out] = inked(a, box);
  EXPECT_GT(in, 100);
  EXPECT_EQ(out, 0);
  long dark = 0;  // the font is antialiased: count pixels mostly covered
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      dark += a.at(x, y).r < 100 && a.at(x, y).g < 100 && a.at(x, y).b < 100;
  EXPECT_GT(dark, 40);

  Canvas b(200, 60);
  const auto right =
      b.text(190, 30, "depth 123 [mm]", colors::black, 14, Canvas::Align::end, Canvas::Align::centre);
  EXPECT_EQ(right[0] + right[2], 190);
  EXPECT_EQ(right[2], box[2]);
  EXPECT_NEAR(right[1] + right[3] / 2.0, 30, 1);
  EXPECT_EQ(inked(b, right).second, 0);
  EXPECT_GT(b.text(0, 0, "depth 123 [mm] and more", colors::black, 14)[2], box[2]);

  Canvas v(60, 200);
  const auto up =
      v.text(5, 100, "depth 123 [mm]", colors::black, 14, Canvas::Align::start, Canvas::Align::centre, true);
  EXPECT_EQ(up[2], box[3]);
  EXPECT_EQ(up[3], box[2]);
  const auto [vin, vout] = inked(v, up);
  EXPECT_EQ(vin, in);  // the same glyph coverage, turned
  EXPECT_EQ(vout, 0);
  EXPECT_EQ(Canvas(5, 5).text(1, 1, "", colors::black)[2], 0);
  EXPECT_EQ(Canvas::text_size("depth 123 [mm]", 14), (std::array<int, 2>{{box[2], box[3]}}));
  EXPECT_EQ(Canvas::text_size("", 14), (std::array<int, 2>{{0, 0}}));
}

TEST(Figures, TetSlicePolygonIsTheCrossSection) {
  const std::array<Eigen::Vector3d, 4> x = {{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 0, 0),
                                             Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(0, 0, 2)}};
  const auto p = tet_slice_polygon(x, 2, 1.0);  // triangle (0,0),(1,0),(0,1)
  ASSERT_EQ(p.size(), 3u);
  double area = 0;
  for (std::size_t k = 0; k < 3; ++k) area += p[k].x() * p[(k + 1) % 3].y() - p[(k + 1) % 3].x() * p[k].y();
  EXPECT_NEAR(std::abs(area) / 2, 0.5, 1e-12);
  EXPECT_TRUE(tet_slice_polygon(x, 2, 3.0).empty());
  EXPECT_EQ(tet_slice_polygon(x, 0, 1.0).size(), 3u);
}

TEST(Figures, ThreeSlicesShowImageAndMeshCrossSection) {
  const auto dir = figures_dir("slices");
  const auto im = gradient_image<3>({{20, 16, 12}}, {{1.0, 1.5, 2.0}});
  const auto model = grid_model_over<3>(im.image, {{4, 4, 4}});
  const Eigen::Vector3d slice(7.0, 6.0, 10.0);  // voxel centre (7, 4, 5), off every node plane
  nlohmann::json report;
  report["figures"]["mesh"] = write_mesh_figures<3>(im, model, dir, &slice);
  const auto& info = report["figures"]["mesh"];
  ASSERT_EQ(info["slices"].size(), 3u);
  const double lo = 0.0, hi = 19 + 2 * 15 + 3 * 11;  // image value range

  const char* names[3] = {"sagittal", "coronal", "axial"};
  for (int axis = 0; axis < 3; ++axis) {
    const fs::path file = dir / "figures" / (std::string("slice_") + names[axis] + ".png");
    ASSERT_TRUE(fs::exists(file)) << file;
    const Canvas c = Canvas::read_png(file);
    // Pixel mapping recomputed from the image box: 360 px on the longer in-plane side.
    const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
    const auto bmin = im.image.box_min(), bmax = im.image.box_max();
    const double eu = bmax[u] - bmin[u], ev = bmax[v] - bmin[v];
    const double scale = 360.0 / std::max(eu, ev);
    const int w = static_cast<int>(std::ceil(eu * scale - 1e-9)),
              h = static_cast<int>(std::ceil(ev * scale - 1e-9));
    const int right_x0 = 24 + w;
    EXPECT_EQ(c.width(), right_x0 + w + 12);
    EXPECT_EQ(c.height(), h + 3 * 12 + 14 + 18);  // + the colour bar's text row
    EXPECT_GT(brightness_variance(c), 0.0);
    // Under the image panel, the slice's name and voxel in text; under the element panel, the bar.
    long ink = 0;
    for (int y = 12 + h + 12; y < 12 + h + 12 + 16; ++y)
      for (int x = 12; x < 12 + w; ++x) ink += c.at(x, y) != colors::white;
    EXPECT_GT(ink, 100) << names[axis];
    EXPECT_EQ(c.at(right_x0, 12 + h + 12 + 7), viridis(0.0));
    EXPECT_EQ(c.at(right_x0 + w - 1, 12 + h + 12 + 7), viridis(1.0));
    auto left_px = [&](const Eigen::Vector3d& p) {
      return Eigen::Vector2d(12 + (p[u] - bmin[u]) * scale, 12 + (p[v] - bmin[v]) * scale);
    };

    long cut = 0, checked = 0, mean_coloured = 0;
    for (std::size_t cell = 0; cell < model.mesh.n_cells(); ++cell) {
      const auto pts = crossings(cell_points(model.mesh, cell), axis, slice[axis]);
      if (pts.size() < 3) continue;
      ++cut;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const auto& p : pts) {
        const Eigen::Vector2d q = left_px(p);
        const std::string what = std::string(names[axis]) + " cell " + std::to_string(cell);
        expect_line_through(
            q.x(), q.y(), [&](int x, int y) { return red_share(c.at(x, y)); }, what);
        expect_line_through(
            q.x() + right_x0 - 12, q.y(), [&](int x, int y) { return black_share(c, x, y); }, what);
        centre += p / static_cast<double>(pts.size());
        ++checked;
      }
      // Inside the section (away from outlines) the right panel shows the element mean.
      // (A thin section's centre may lie on its outline: then the pixel is darkened by the black line.)
      const Eigen::Vector2d q = left_px(centre);
      const int qx = static_cast<int>(std::floor(q.x())) + right_x0 - 12,
                qy = static_cast<int>(std::floor(q.y()));
      const Rgb inside = c.at(qx, qy);
      const Rgb expected = viridis((model.values[cell].mean - lo) / (hi - lo));
      EXPECT_TRUE(inside == expected || black_share(c, qx, qy) > 0.1);
      mean_coloured += inside == expected;
    }
    EXPECT_EQ(info["slices"][axis]["cut_elements"].get<long>(), cut);
    EXPECT_GT(checked, 20);
    EXPECT_GT(mean_coloured, cut / 2);
    // The image itself: pixel centres away from outlines show the nearest voxel's grey value.
    long grey_ok = 0, grey_seen = 0;
    for (int py = 0; py < h; py += 7)
      for (int px = 0; px < w; px += 7) {
        const Rgb got = c.at(12 + px, 12 + py);
        if (red_share(got) > 0.0) continue;  // an outline crosses the pixel
        std::array<long, 3> i = {{7, 4, 5}};
        i[u] = std::lround((bmin[u] + (px + 0.5) / scale - im.image.origin[u]) / im.image.spacing[u]);
        i[v] = std::lround((bmin[v] + (py + 0.5) / scale - im.image.origin[v]) / im.image.spacing[v]);
        i[u] = std::clamp(i[u], 0L, im.image.size[u] - 1);
        i[v] = std::clamp(i[v], 0L, im.image.size[v] - 1);
        ++grey_seen;
        grey_ok += got == grey((im.image.at(i) - lo) / (hi - lo));
      }
    EXPECT_GT(grey_seen, 100);
    EXPECT_GE(grey_ok, grey_seen * 95 / 100);  // ties at exact voxel borders may round either way
  }
  for (const auto& e : fs::directory_iterator(dir / "figures"))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos);
}

TEST(Figures, DefaultSlicePointIsTheImageCentre) {
  const auto dir = figures_dir("centre");
  const auto im = gradient_image<3>({{6, 5, 4}}, {{1.0, 1.0, 3.0}});
  const auto model = grid_model_over<3>(im.image, {{2, 2, 2}});
  nlohmann::json report;
  report["figures"]["mesh"] = write_mesh_figures<3>(im, model, dir, nullptr);
  const auto p = report["figures"]["mesh"]["slice_point_frame"].get<std::vector<double>>();
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0], 3.0);  // voxel lround(2.5) = 3
  EXPECT_EQ(p[1], 2.0);
  EXPECT_EQ(p[2], 6.0);  // voxel lround(1.5) = 2, spacing 3
}

TEST(Figures, TwoDimensionalOverlayAndDiscretizedImage) {
  const auto dir = figures_dir("2d");
  const auto im = gradient_image<2>({{24, 18}}, {{1.0, 0.5}});
  const auto model = grid_model_over<2>(im.image, {{5, 4}});
  nlohmann::json report;
  report["figures"]["mesh"] = write_mesh_figures<2>(im, model, dir, nullptr);
  const Canvas overlay = Canvas::read_png(dir / "figures" / "mesh_overlay.png");
  const Canvas disc = Canvas::read_png(dir / "figures" / "discretized.png");
  const auto bmin = im.image.box_min(), bmax = im.image.box_max();
  const double scale = 512.0 / std::max(bmax[0] - bmin[0], bmax[1] - bmin[1]);
  const int w = static_cast<int>(std::ceil((bmax[0] - bmin[0]) * scale - 1e-9));
  const int h = static_cast<int>(std::ceil((bmax[1] - bmin[1]) * scale - 1e-9));
  for (const Canvas* c : {&overlay, &disc}) {
    EXPECT_EQ(c->width(), w + 24);
    EXPECT_EQ(c->height(), h + 3 * 12 + 14 + 18);  // + the grey bar and its text row
    EXPECT_GT(brightness_variance(*c), 0.0);
    // The grey bar under the panel: the range's low end (black) on the left, its high end on the right.
    const int bar_row = 12 + h + 12 + 7;
    EXPECT_EQ(c->at(12, bar_row), grey(0.0));
    EXPECT_EQ(c->at(12 + w - 1, bar_row), grey(1.0));
  }
  auto px = [&](const Eigen::Vector2d& p) {
    return Eigen::Vector2d(12 + (p[0] - bmin[0]) * scale, 12 + (p[1] - bmin[1]) * scale);
  };
  const double lo = 0.0, hi = 23 + 2 * 17;
  long red = 0;
  for (int y = 12; y < 12 + h; ++y)
    for (int x = 12; x < 12 + w; ++x) red += red_share(overlay.at(x, y)) > 0.0;
  EXPECT_LT(red, static_cast<long>(w) * h / 5);  // outlines, not a red blob
  for (std::size_t cell = 0; cell < model.mesh.n_cells(); ++cell) {
    const auto x = cell_points(model.mesh, cell);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d a = px(x[k]), b = px(x[(k + 1) % 3]);
      auto red = [&](int x, int y) { return red_share(overlay.at(x, y)); };
      expect_line_through(a.x(), a.y(), red, "vertex of cell " + std::to_string(cell));
      expect_line_through(0.5 * (a.x() + b.x()), 0.5 * (a.y() + b.y()), red,
                          "edge of cell " + std::to_string(cell));
    }
    const Eigen::Vector2d m = px(centroid<2>(x));
    EXPECT_EQ(disc.at(static_cast<int>(std::floor(m.x())), static_cast<int>(std::floor(m.y()))),
              grey((model.values[cell].mean - lo) / (hi - lo)))
        << "cell " << cell;
  }
}

TEST(Figures, EnergyPlotIsNormalisedToTheFirstIteration) {
  const auto dir = figures_dir("energy");
  std::vector<IterationRecord> h(4);
  const double e[] = {2.0, 1.6, 1.4, 1.3}, g[] = {10, 9, 8.5, 8.4}, d[] = {5, 3, 2, 1.5};
  for (int k = 0; k < 4; ++k)
    h[k].iteration = k, h[k].energy = e[k], h[k].geometric = g[k], h[k].discretization = d[k];
  const auto j = write_energy_plot(h, dir / "energy.png");
  const Canvas c = Canvas::read_png(dir / "energy.png");
  EXPECT_EQ(c.width(), 700);
  EXPECT_EQ(c.height(), 470);
  EXPECT_GT(brightness_variance(c), 0.0);
  const auto xr = j["x_range"].get<std::vector<double>>(), yr = j["y_range"].get<std::vector<double>>();
  const auto area = j["plot_area"].get<std::vector<int>>();  // left, top, right, bottom
  ASSERT_EQ(area.size(), 4u);
  EXPECT_EQ(j["x_label"], "iteration");
  EXPECT_LE(xr[0], 0.0);
  EXPECT_GE(xr[1], 3.0);
  EXPECT_LE(yr[0], 0.3);  // E_D/E_D0 at the last iteration
  EXPECT_GE(yr[1], 1.0);
  EXPECT_LT(yr[1] - yr[0], 2.0);  // normalised, not absolute (E_G would reach 10)
  auto px = [&](double x) { return area[0] + (x - xr[0]) / (xr[1] - xr[0]) * (area[2] - area[0]); };
  auto py = [&](double y) { return area[3] - (y - yr[0]) / (yr[1] - yr[0]) * (area[3] - area[1]); };
  // The curves are 2-pixel anti-aliased lines: a pixel near each point is (almost) wholly covered,
  // within 48 of the series colour in each channel (the series colours differ by more than 100).
  for (int k = 1; k < 4; ++k) {
    EXPECT_TRUE(near_colour(c, px(k), py(e[k] / e[0]), series_color(0), 2, 48)) << k;
    EXPECT_TRUE(near_colour(c, px(k), py(g[k] / g[0]), series_color(1), 2, 48)) << k;
    EXPECT_TRUE(near_colour(c, px(k), py(d[k] / d[0]), series_color(2), 2, 48)) << k;
  }
  EXPECT_FALSE(near_colour(c, px(3), py(0.95), series_color(2), 2, 48));  // no E_D curve up there at the end
}

TEST(Figures, LinePlotSkipsNonFiniteValues) {
  const auto dir = figures_dir("line");
  const auto j = write_line_plot(dir / "force.png", {0, 1, 2, 3}, {{0.0, NAN, 2.0, 3.0}}, {"force"});
  EXPECT_TRUE(fs::exists(dir / "force.png"));
  EXPECT_EQ(j["y_range"][1].get<double>(), 3.0);
  EXPECT_EQ(j["series"][0]["name"], "force");
}

// Tick values under the x axis and left of the y axis, both axis titles and the legend are drawn:
// ink in those margins, none where a plot without text leaves them white.
TEST(Figures, LinePlotHasTickValuesTitlesAndLegend) {
  const auto dir = figures_dir("labels");
  auto plot = [&](const std::string& name, std::vector<std::string> names, const std::string& xl,
                  const std::string& yl) {
    const auto j =
        write_line_plot(dir / name, {0, 10, 20}, {{0.0, 5.0, 40.0}, {1.0, 2.0, 3.0}}, names, xl, yl);
    return std::make_pair(j, Canvas::read_png(dir / name));
  };
  const auto [j, c] = plot("with.png", {"axial force", "lateral force"}, "needle depth [mm]", "force [mN]");
  const auto [j0, c0] = plot("without.png", {}, "", "");
  const auto area = j["plot_area"].get<std::vector<int>>();
  auto ink = [](const Canvas& canvas, int x0, int y0, int x1, int y1) {
    long n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) n += canvas.at(x, y) != colors::white;
    return n;
  };
  // y tick values: between the y title's column and the tick marks; x tick values: under the ticks.
  EXPECT_GT(ink(c, 24, area[1], area[0] - 6, area[3]), 50);
  EXPECT_GT(ink(c, area[0], area[3] + 7, area[2], area[3] + 24), 50);
  // Titles: the x title at the bottom, the y title in the leftmost column; absent without labels.
  EXPECT_GT(ink(c, area[0], c.height() - 22, area[2], c.height()), 50);
  EXPECT_GT(ink(c, 0, area[1], 22, area[3]), 50);
  EXPECT_EQ(ink(c0, area[0], c0.height() - 22, area[2], c0.height()), 0);
  EXPECT_EQ(ink(c0, 0, area[1], 22, area[3]), 0);
  // Legend: names next to their line samples in a row above the plot, not over the data.
  EXPECT_GT(ink(c, area[0] + 28, 0, area[2], area[1] - 2), 100);
  EXPECT_EQ(ink(c0, area[0], 0, c0.width(), area[1] - 2), 0);  // (left of the axis: the top tick value)
  EXPECT_TRUE(near_colour(c, area[0] + 11, area[1] / 2, series_color(0), 1));
  long second = 0;  // the second sample sits after the first name
  for (int x = area[0] + 60; x < area[2]; ++x) second += c.at(x, area[1] / 2) == series_color(1);
  EXPECT_GT(second, 10);
  EXPECT_EQ(j["x_label"], "needle depth [mm]");
  EXPECT_EQ(j["y_label"], "force [mN]");
}

TEST(Figures, DeformedSliceFollowsTheDisplacement) {
  const auto dir = figures_dir("deformed");
  const auto im = gradient_image<3>({{8, 8, 8}}, {{1.0, 1.0, 1.0}});
  const auto model = grid_model_over<3>(im.image, {{3, 3, 3}});
  const Eigen::Vector3d shift(2.0, 1.0, 0.0);
  std::vector<Eigen::Vector3d> u(model.mesh.n_points(), shift);
  const Eigen::Vector3d slice(3.0, 3.0, 3.3);
  const auto j = write_deformed_slice<3>(model, u, dir / "deformed.png", slice, 2);
  EXPECT_NEAR(j["displacement_range"][1].get<double>(), shift.norm(), 1e-12);
  const Canvas c = Canvas::read_png(dir / "deformed.png");
  EXPECT_GT(brightness_variance(c), 0.0);
  // Bounds of undeformed + deformed nodes in (x, y), padded by 2 % of the larger extent.
  const auto bmin = im.image.box_min(), bmax = im.image.box_max();
  const Eigen::Vector2d lo(bmin[0], bmin[1]), hi(bmax[0] + shift[0], bmax[1] + shift[1]);
  const double pad = 0.02 * (hi - lo).maxCoeff() + 1e-12;
  const double scale = 480.0 / ((hi - lo).maxCoeff() + 2 * pad);
  EXPECT_NEAR(j["pixels_per_unit"].get<double>(), scale, 1e-9);
  long checked = 0;
  for (std::size_t cell = 0; cell < model.mesh.n_cells(); ++cell) {
    auto x = cell_points(model.mesh, cell);
    for (auto& p : x) p += shift;
    for (const auto& p : crossings(x, 2, slice[2])) {
      const double px = 12 + (p[0] - lo[0] + pad) * scale, py = 12 + (p[1] - lo[1] + pad) * scale;
      expect_line_through(
          px, py, [&](int x, int y) { return black_share(c, x, y); }, "cell " + std::to_string(cell));
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);
}

// The deformed-mesh figure of a simulation cuts through the tip along the plane that holds the most of
// the needle: normal to the axis of the direction's smallest component (a needle along z was cut
// across, at its tip only, by the fixed z slice).
TEST(Figures, DeformedSliceNormalHoldsTheNeedle) {
  EXPECT_EQ(slice_normal_along(Eigen::Vector3d(1, 0, 0)), 2);
  EXPECT_EQ(slice_normal_along(Eigen::Vector3d(0, 1, 0)), 2);
  EXPECT_EQ(slice_normal_along(Eigen::Vector3d(0, 0, -1)), 1);
  EXPECT_EQ(slice_normal_along(Eigen::Vector3d(0.1, 0.9, 0.42)), 0);
  EXPECT_EQ(slice_normal_along(Eigen::Vector3d(0.6, 0.05, 0.8)), 1);
  // Brute force over random directions: the chosen normal is a smallest component.
  std::mt19937 rng(5);
  std::normal_distribution<double> n;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::Vector3d d(n(rng), n(rng), n(rng));
    const int a = slice_normal_along(d);
    EXPECT_EQ(std::abs(d[a]), d.cwiseAbs().minCoeff()) << d.transpose();
  }
}

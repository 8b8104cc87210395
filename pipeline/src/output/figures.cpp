// Figures (figures.hpp): slices of the image beside the mesh cross-section, the discretized image,
// the Fig. 9 energy history, line plots and the deformed-mesh slice, drawn on png.hpp's canvas.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vim/pipeline/output/figures.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

namespace {

constexpr int kMargin = 12;
constexpr int kBar = 14;    // colour-bar height
constexpr int kLabel = 18;  // text row under a colour bar (its range and caption)
constexpr int kFont = 12;   // tick labels, colour-bar labels

struct Range {
  double lo = 0.0, hi = 1.0;
  double t(double x) const { return hi > lo ? (x - lo) / (hi - lo) : 0.5; }
};

// printf into a std::string (short figure labels).
template <class... Args>
std::string printf_string(const char* format, Args... args) {
  char buf[128];
  std::snprintf(buf, sizeof buf, format, args...);
  return buf;
}

// A number as a tick or range label: 6 significant digits, and 0 for values that are round-off
// next to `scale` (e.g. 5.6e-17 on an axis from -1 to 1).
std::string number_label(double t, double scale) {
  return printf_string("%.6g", std::abs(t) < 1e-9 * std::abs(scale) ? 0.0 : t);
}

// The colour bar (viridis unless `map`) under a panel, from lo (left) to hi (right), with both values
// and the caption on the text row below it (kLabel pixels).
void draw_colorbar(Canvas& canvas, const SliceView& view, int y0, double lo, double hi,
                   const std::string& caption, Rgb (*map)(double) = viridis) {
  for (int x = 0; x < view.width; ++x) {
    const Rgb c = map(view.width > 1 ? static_cast<double>(x) / (view.width - 1) : 0.5);
    for (int y = y0; y < y0 + kBar; ++y) canvas.set(view.x_offset + x, y, c);
  }
  const double scale = std::max(std::abs(lo), std::abs(hi));
  const int ty = y0 + kBar + 2;
  canvas.text(view.x_offset, ty, number_label(lo, scale), colors::axis, kFont);
  canvas.text(view.x_offset + view.width, ty, number_label(hi, scale), colors::axis, kFont,
              Canvas::Align::end);
  canvas.text(view.x_offset + view.width / 2, ty, caption, colors::axis, kFont, Canvas::Align::centre);
}

// In-plane axes of a slice with normal `axis`, ascending.
std::pair<int, int> plane_axes(int axis) {
  if (axis == 0) return {1, 2};
  if (axis == 1) return {0, 2};
  return {0, 1};
}

template <int dim>
std::vector<Eigen::Vector2d> cell_section(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x,
                                          int axis, double s) {
  if constexpr (dim == 3) {
    return tet_slice_polygon(x, axis, s);
  } else {
    (void)axis;
    (void)s;
    return {x[0], x[1], x[2]};
  }
}

std::vector<Eigen::Vector2d> to_pixels(const SliceView& view, const std::vector<Eigen::Vector2d>& plane) {
  std::vector<Eigen::Vector2d> px;
  px.reserve(plane.size());
  for (const auto& q : plane) px.push_back(view.to_pixel(q.x(), q.y()));
  return px;
}

void draw_outline(Canvas& canvas, const std::vector<Eigen::Vector2d>& px, Rgb c) {
  if (px.size() == 1)
    canvas.line(px[0].x(), px[0].y(), px[0].x(), px[0].y(), c);
  else if (px.size() >= 2)
    canvas.polyline_closed(px, c);
}

// 1-2-5 tick step giving about `target` intervals over `span`.
double nice_step(double span, int target) {
  if (!(span > 0.0)) return 1.0;
  const double raw = span / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / p;
  return (f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0) * p;
}

struct Axis {
  double lo, hi, step;
  std::vector<double> ticks;
};

Axis nice_axis(double lo, double hi) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) lo = 0.0, hi = 1.0;
  if (hi <= lo) {
    const double pad = std::max(0.5, 0.05 * std::abs(lo));
    lo -= pad;
    hi += pad;
  }
  Axis a;
  a.step = nice_step(hi - lo, 5);
  a.lo = std::floor(lo / a.step + 1e-9) * a.step;
  a.hi = std::ceil(hi / a.step - 1e-9) * a.step;
  for (int k = 0;; ++k) {
    const double t = a.lo + k * a.step;
    if (t > a.hi + 1e-9 * a.step) break;
    a.ticks.push_back(std::abs(t) < 1e-12 * a.step ? 0.0 : t);
  }
  a.lo = std::min(a.lo, lo);  // k·step may round just past the data (3·0.1 > 0.3)
  a.hi = std::max(a.hi, hi);
  return a;
}

}  // namespace

SliceView make_slice_view(int axis, int u, int v, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                          int max_pixels) {
  const Eigen::Vector2d extent = hi - lo;
  if (!(extent.minCoeff() > 0.0) || !extent.allFinite())
    throw std::invalid_argument("figure panel needs a rectangle with positive extent");
  SliceView view;
  view.axis = axis;
  view.u = u;
  view.v = v;
  view.u_min = lo.x();
  view.v_min = lo.y();
  view.scale = max_pixels / extent.maxCoeff();
  view.width = std::max(1, static_cast<int>(std::ceil(extent.x() * view.scale - 1e-9)));
  view.height = std::max(1, static_cast<int>(std::ceil(extent.y() * view.scale - 1e-9)));
  return view;
}

std::vector<SliceView> projection_panels(const std::vector<std::array<Eigen::Vector2d, 2>>& boxes,
                                         int panel_pixels, int margin, int top, bool stacked) {
  double longest = 0.0;
  for (const auto& [lo, hi] : boxes) {
    const Eigen::Vector2d extent = hi - lo;
    if (!(extent.minCoeff() > 0.0) || !extent.allFinite())
      throw std::invalid_argument("figure panel needs a rectangle with positive extent");
    longest = std::max(longest, extent.maxCoeff());
  }
  std::vector<SliceView> views;
  int x = margin, y = top;
  for (const auto& [lo, hi] : boxes) {
    const Eigen::Vector2d extent = hi - lo;
    SliceView view;
    view.u_min = lo.x();
    view.v_min = lo.y();
    view.scale = panel_pixels / longest;  // one scale for all
    view.width = std::max(1, static_cast<int>(std::ceil(extent.x() * view.scale - 1e-9)));
    view.height = std::max(1, static_cast<int>(std::ceil(extent.y() * view.scale - 1e-9)));
    view.x_offset = x;
    view.y_offset = y;
    if (stacked)
      y += view.height + top;
    else
      x += view.width + margin;
    views.push_back(view);
  }
  return views;
}

void draw_panel(Canvas& canvas, const SliceView& view, const std::string& caption, int caption_y) {
  canvas.polyline_closed({{view.x_offset, view.y_offset},
                          {view.x_offset + view.width, view.y_offset},
                          {view.x_offset + view.width, view.y_offset + view.height},
                          {view.x_offset, view.y_offset + view.height}},
                         colors::light_grey);
  canvas.text(view.x_offset, caption_y, caption, colors::axis, 12);
}

nlohmann::json panel_report(const SliceView& view) {
  return {{"u_min", view.u_min},       {"v_min", view.v_min},       {"scale", view.scale},
          {"x_offset", view.x_offset}, {"y_offset", view.y_offset}, {"width", view.width},
          {"height", view.height}};
}

std::vector<Eigen::Vector2d> tet_slice_polygon(const std::array<Eigen::Vector3d, 4>& x, int axis, double s) {
  const auto [u, v] = plane_axes(axis);
  double d[4];
  for (int i = 0; i < 4; ++i) d[i] = x[i][axis] - s;
  std::vector<Eigen::Vector2d> pts;
  auto add = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d q(p[u], p[v]);
    for (const auto& r : pts)
      if ((r - q).norm() <= 1e-12 * (1.0 + q.norm())) return;
    pts.push_back(q);
  };
  for (int i = 0; i < 4; ++i)
    if (d[i] == 0.0) add(x[i]);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if ((d[i] < 0.0 && d[j] > 0.0) || (d[i] > 0.0 && d[j] < 0.0)) {
        const double t = d[i] / (d[i] - d[j]);
        add(x[i] + t * (x[j] - x[i]));
      }
  if (pts.size() >= 3) {  // the section is convex: order by angle about the centroid
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : pts) c += p;
    c /= static_cast<double>(pts.size());
    std::sort(pts.begin(), pts.end(), [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
      return std::atan2(a.y() - c.y(), a.x() - c.x()) < std::atan2(b.y() - c.y(), b.x() - c.x());
    });
  }
  return pts;
}

const char* slice_name(int axis) {
  switch (axis) {
    case 0:
      return "sagittal";
    case 1:
      return "coronal";
    case 2:
      return "axial";
    default:
      return "plane";
  }
}

template <int dim>
std::array<SliceView, 2> mesh_figure_views(const Image<dim>& image, int axis) {
  const auto bmin = image.box_min(), bmax = image.box_max();
  int u = 0, v = 1;
  if constexpr (dim == 3)
    std::tie(u, v) = plane_axes(axis);
  else
    axis = -1;
  const int max_pixels = dim == 3 ? 360 : 512;
  SliceView left = make_slice_view(axis, u, v, {bmin[u], bmin[v]}, {bmax[u], bmax[v]}, max_pixels);
  left.x_offset = kMargin;
  left.y_offset = kMargin;
  SliceView right = left;
  if constexpr (dim == 3) right.x_offset = 2 * kMargin + left.width;
  return {{left, right}};
}

template <int dim>
nlohmann::json write_mesh_figures(const OrientedImage<dim>& oriented, const MeshModel<dim>& model,
                                  const fs::path& dir, const Eigen::Matrix<double, dim, 1>* slice_point) {
  using Point = Eigen::Matrix<double, dim, 1>;
  const Image<dim>& image = oriented.image;
  if (image.data.empty()) throw std::invalid_argument("write_mesh_figures: empty image");
  if (model.values.size() != model.mesh.n_cells())
    throw std::invalid_argument("write_mesh_figures: model needs one value per element");
  const fs::path fig_dir = dir / "figures";
  fs::create_directories(fig_dir);

  Range range;
  const auto [mn, mx] = std::minmax_element(image.data.begin(), image.data.end());
  range.lo = *mn;
  range.hi = *mx;

  // The slice point snapped to the nearest voxel-centre plane on each axis.
  Point centre;
  typename Image<dim>::Index index{};
  for (int a = 0; a < dim; ++a) {
    const double want =
        slice_point ? (*slice_point)[a] : image.origin[a] + 0.5 * (image.size[a] - 1) * image.spacing[a];
    index[a] = std::clamp(std::lround((want - image.origin[a]) / image.spacing[a]), 0L, image.size[a] - 1);
  }
  centre = image.point_of(index);

  nlohmann::json info;
  info["value_range"] = {range.lo, range.hi};
  info["colormap"] = "viridis (element means), grey (image), red/black element outlines";
  info["slice_point_frame"] = std::vector<double>(centre.data(), centre.data() + dim);
  const Point world = oriented.to_world(centre);
  info["slice_point_world"] = std::vector<double>(world.data(), world.data() + dim);
  info["files"] = nlohmann::json::array();

  auto render_image = [&](Canvas& canvas, const SliceView& view) {
    for (int py = 0; py < view.height; ++py)
      for (int px = 0; px < view.width; ++px) {
        const Eigen::Vector2d q = view.to_plane(view.x_offset + px + 0.5, view.y_offset + py + 0.5);
        typename Image<dim>::Index i = index;
        const double c[2] = {q.x(), q.y()};
        const int axes[2] = {view.u, view.v};
        for (int k = 0; k < 2; ++k)
          i[axes[k]] = std::clamp(std::lround((c[k] - image.origin[axes[k]]) / image.spacing[axes[k]]), 0L,
                                  image.size[axes[k]] - 1);
        canvas.set(view.x_offset + px, view.y_offset + py, grey(range.t(image.at(i))));
      }
  };

  auto sections = [&](int axis, double s) {
    std::vector<std::pair<std::size_t, std::vector<Eigen::Vector2d>>> out;
    for (std::size_t c = 0; c < model.mesh.n_cells(); ++c) {
      const auto x = cell_points(model.mesh, c);
      if constexpr (dim == 3) {
        double lo = x[0][axis], hi = x[0][axis];
        for (const auto& p : x) lo = std::min(lo, p[axis]), hi = std::max(hi, p[axis]);
        if (s < lo || s > hi) continue;
      }
      auto poly = cell_section<dim>(x, axis, s);
      if (!poly.empty()) out.emplace_back(c, std::move(poly));
    }
    return out;
  };

  if constexpr (dim == 3) {
    info["slices"] = nlohmann::json::array();
    for (int axis = 0; axis < 3; ++axis) {
      const auto views = mesh_figure_views(image, axis);
      const SliceView& left = views[0];
      const SliceView& right = views[1];
      Canvas canvas(right.x_offset + right.width + kMargin, left.height + 3 * kMargin + kBar + kLabel);
      render_image(canvas, left);
      const auto cut = sections(axis, centre[axis]);
      for (const auto& [c, poly] : cut)
        if (poly.size() >= 3)
          canvas.fill_polygon(to_pixels(right, poly), viridis(range.t(model.values[c].mean)));
      for (const auto& [c, poly] : cut) {
        draw_outline(canvas, to_pixels(left, poly), colors::outline);
        draw_outline(canvas, to_pixels(right, poly), colors::black);
      }
      draw_colorbar(canvas, right, left.y_offset + left.height + kMargin, range.lo, range.hi, "element mean");
      // Under the image panel: which slice this is (its world point is in report.json), in the
      // longest form that fits the panel's width.
      const long k = static_cast<long>(index[axis]), n = static_cast<long>(image.size[axis]);
      for (const std::string& where :
           {printf_string("%s slice: voxel %ld of %ld on image axis %d; image + mesh", slice_name(axis), k, n,
                          axis),
            printf_string("%s: voxel %ld/%ld, axis %d", slice_name(axis), k, n, axis),
            printf_string("voxel %ld/%ld", k, n)})
        if (Canvas::text_size(where, kFont)[0] <= left.width) {
          canvas.text(left.x_offset, left.y_offset + left.height + kMargin, where, colors::axis, kFont);
          break;
        }
      const fs::path file = fig_dir / (std::string("slice_") + slice_name(axis) + ".png");
      canvas.write_png(file);
      info["files"].push_back(file.string());
      info["slices"].push_back({{"file", file.string()},
                                {"name", slice_name(axis)},
                                {"normal_axis", axis},
                                {"frame_coordinate", centre[axis]},
                                {"voxel_index", index[axis]},
                                {"cut_elements", cut.size()},
                                {"pixels_per_unit", left.scale},
                                {"panel_pixels", {left.width, left.height}}});
    }
  } else {
    const auto views = mesh_figure_views(image, -1);
    const SliceView& view = views[0];
    const auto cut = sections(-1, 0.0);
    const int bar_y = view.y_offset + view.height + kMargin;
    Canvas overlay(view.width + 2 * kMargin, view.height + 3 * kMargin + kBar + kLabel);
    render_image(overlay, view);
    for (const auto& [c, poly] : cut) draw_outline(overlay, to_pixels(view, poly), colors::outline);
    draw_colorbar(overlay, view, bar_y, range.lo, range.hi, "image value", grey);
    const fs::path f1 = fig_dir / "mesh_overlay.png";
    overlay.write_png(f1);

    Canvas discretized(view.width + 2 * kMargin, view.height + 3 * kMargin + kBar + kLabel);
    for (const auto& [c, poly] : cut) {
      // Each element also stroked in its own colour: no background seams between anti-aliased fills.
      const Rgb g = grey(range.t(model.values[c].mean));
      discretized.fill_polygon(to_pixels(view, poly), g);
      discretized.polyline_closed(to_pixels(view, poly), g);
    }
    draw_colorbar(discretized, view, bar_y, range.lo, range.hi, "element mean", grey);
    const fs::path f2 = fig_dir / "discretized.png";
    discretized.write_png(f2);
    info["files"] = {f1.string(), f2.string()};
    info["pixels_per_unit"] = view.scale;
    info["panel_pixels"] = {view.width, view.height};
  }
  return info;
}

nlohmann::json write_line_plot(const fs::path& path, const std::vector<double>& x,
                               const std::vector<std::vector<double>>& series,
                               const std::vector<std::string>& names, const std::string& x_label,
                               const std::string& y_label) {
  constexpr int W = 700, H = 470, L = 90, R = 20, T = 34, B = 58;
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) continue;
    bool any = false;
    for (const auto& s : series)
      if (k < s.size() && std::isfinite(s[k])) {
        ylo = std::min(ylo, s[k]);
        yhi = std::max(yhi, s[k]);
        any = true;
      }
    if (any) xlo = std::min(xlo, x[k]), xhi = std::max(xhi, x[k]);
  }
  const Axis ax = nice_axis(xlo, xhi), ay = nice_axis(ylo, yhi);
  auto px = [&](double v) { return L + (v - ax.lo) / (ax.hi - ax.lo) * (W - L - R); };
  auto py = [&](double v) { return (H - B) - (v - ay.lo) / (ay.hi - ay.lo) * (H - T - B); };

  Canvas canvas(W, H);
  // Grid, ticks and frame: 1-pixel lines through the centres of the pixels they fall in (sharp).
  auto crisp = [](double v) { return std::floor(v) + 0.5; };
  for (double t : ax.ticks) {
    canvas.line(crisp(px(t)), crisp(T), crisp(px(t)), crisp(H - B), colors::light_grey);
    canvas.line(crisp(px(t)), crisp(H - B), crisp(px(t)), crisp(H - B + 5), colors::axis);
  }
  for (double t : ay.ticks) {
    canvas.line(crisp(L), crisp(py(t)), crisp(W - R), crisp(py(t)), colors::light_grey);
    canvas.line(crisp(L - 5), crisp(py(t)), crisp(L), crisp(py(t)), colors::axis);
  }
  canvas.line(crisp(L), crisp(T), crisp(L), crisp(H - B), colors::axis);
  canvas.line(crisp(L), crisp(H - B), crisp(W - R), crisp(H - B), colors::axis);
  canvas.line(crisp(L), crisp(T), crisp(W - R), crisp(T), colors::axis);
  canvas.line(crisp(W - R), crisp(T), crisp(W - R), crisp(H - B), colors::axis);
  // Tick values, axis titles.
  const double xs = std::max(std::abs(ax.lo), std::abs(ax.hi)),
               ys = std::max(std::abs(ay.lo), std::abs(ay.hi));
  for (double t : ax.ticks)
    canvas.text(static_cast<int>(std::lround(px(t))), H - B + 8, number_label(t, xs), colors::axis, kFont,
                Canvas::Align::centre);
  for (double t : ay.ticks)
    canvas.text(L - 8, static_cast<int>(std::lround(py(t))), number_label(t, ys), colors::axis, kFont,
                Canvas::Align::end, Canvas::Align::centre);
  canvas.text(L + (W - L - R) / 2, H - 6, x_label, colors::black, kFont + 1, Canvas::Align::centre,
              Canvas::Align::end);
  canvas.text(4, T + (H - T - B) / 2, y_label, colors::black, kFont + 1, Canvas::Align::start,
              Canvas::Align::centre, true);

  nlohmann::json names_json = nlohmann::json::array();
  for (std::size_t s = 0; s < series.size(); ++s) {
    const Rgb c = series_color(static_cast<int>(s));
    bool have_prev = false;
    double x0 = 0, y0 = 0;
    for (std::size_t k = 0; k < std::min(x.size(), series[s].size()); ++k) {
      if (!std::isfinite(x[k]) || !std::isfinite(series[s][k])) {
        have_prev = false;
        continue;
      }
      const double x1 = px(x[k]), y1 = py(series[s][k]);
      if (have_prev)
        canvas.line(x0, y0, x1, y1, c, 2);
      else
        canvas.fill_rect(static_cast<int>(x1) - 1, static_cast<int>(y1) - 1, static_cast<int>(x1) + 1,
                         static_cast<int>(y1) + 1, c);
      x0 = x1, y0 = y1, have_prev = true;
    }
    const Rgb col = series_color(static_cast<int>(s));
    names_json.push_back({{"name", s < names.size() ? names[s] : "series " + std::to_string(s)},
                          {"color", {col.r, col.g, col.b}}});
  }
  // Legend above the plot (never over the data): a line sample and the name of each series, in a row.
  int legend_x = L;
  for (std::size_t k = 0; k < std::min(names.size(), series.size()); ++k) {
    const int y = T / 2;
    canvas.line(legend_x, y, legend_x + 22, y, series_color(static_cast<int>(k)), 2);
    const auto box = canvas.text(legend_x + 28, y, names[k], colors::black, kFont, Canvas::Align::start,
                                 Canvas::Align::centre);
    legend_x = box[0] + box[2] + 18;
  }
  canvas.write_png(path);
  return {{"file", path.string()}, {"x_range", {ax.lo, ax.hi}}, {"y_range", {ay.lo, ay.hi}},
          {"x_ticks", ax.ticks},   {"y_ticks", ay.ticks},       {"series", names_json},
          {"x_label", x_label},    {"y_label", y_label},        {"plot_area", {L, T, W - R, H - B}}};
}

nlohmann::json write_energy_plot(const std::vector<vim::IterationRecord>& history, const fs::path& path) {
  if (history.empty()) throw std::invalid_argument("write_energy_plot: empty history");
  std::vector<double> it, e, eg, ed;
  const auto& h0 = history.front();
  auto ratio = [](double a, double b) { return b != 0.0 ? a / b : std::numeric_limits<double>::quiet_NaN(); };
  for (const auto& h : history) {
    it.push_back(h.iteration);
    e.push_back(ratio(h.energy, h0.energy));
    eg.push_back(ratio(h.geometric, h0.geometric));
    ed.push_back(ratio(h.discretization, h0.discretization));
  }
  nlohmann::json j = write_line_plot(path, it, {e, eg, ed}, {"E/E(0)", "E_G/E_G(0)", "E_D/E_D(0)"},
                                     "iteration", "energy relative to the initial mesh");
  j["normalisation"] = "each series divided by its value at history[0] (the initial mesh)";
  return j;
}

template <int dim>
nlohmann::json write_deformed_slice(const MeshModel<dim>& model,
                                    const std::vector<Eigen::Matrix<double, dim, 1>>& displacement,
                                    const fs::path& path, const Eigen::Matrix<double, dim, 1>& slice_point,
                                    int normal_axis, const std::string& caption) {
  using Point = Eigen::Matrix<double, dim, 1>;
  const auto& mesh = model.mesh;
  if (displacement.size() != mesh.n_points())
    throw std::invalid_argument("write_deformed_slice: one displacement per mesh node is required");
  if (mesh.n_points() == 0) throw std::invalid_argument("write_deformed_slice: empty mesh");
  int axis = -1, u = 0, v = 1;
  if constexpr (dim == 3) {
    if (normal_axis < 0 || normal_axis > 2)
      throw std::invalid_argument("write_deformed_slice: normal_axis must be 0, 1 or 2");
    axis = normal_axis;
    std::tie(u, v) = plane_axes(axis);
  }
  std::vector<Point> deformed(mesh.n_points());
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = Eigen::Vector2d::Constant(-INFINITY);
  double umax = 0.0;
  for (std::size_t i = 0; i < mesh.n_points(); ++i) {
    deformed[i] = mesh.points[i] + displacement[i];
    umax = std::max(umax, displacement[i].norm());
    for (const Point& p : {mesh.points[i], deformed[i]}) {
      lo = lo.cwiseMin(Eigen::Vector2d(p[u], p[v]));
      hi = hi.cwiseMax(Eigen::Vector2d(p[u], p[v]));
    }
  }
  const double pad = 0.02 * (hi - lo).maxCoeff() + 1e-12;
  SliceView view = make_slice_view(axis, u, v, lo.array() - pad, hi.array() + pad, 480);
  view.x_offset = view.y_offset = kMargin;
  Canvas canvas(view.width + 2 * kMargin, view.height + 3 * kMargin + kBar + kLabel);
  const double s = dim == 3 ? slice_point[std::max(axis, 0)] : 0.0;
  Range range{0.0, umax > 0.0 ? umax : 1.0};

  std::vector<std::vector<Eigen::Vector2d>> undeformed_polys, deformed_polys;
  std::vector<double> magnitude;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    std::array<Point, dim + 1> x0, x1;
    double mag = 0.0;
    for (int k = 0; k <= dim; ++k) {
      x0[k] = mesh.points[mesh.cells[c][k]];
      x1[k] = deformed[mesh.cells[c][k]];
      mag += displacement[mesh.cells[c][k]].norm() / (dim + 1);
    }
    auto p0 = cell_section<dim>(x0, axis, s);
    if (!p0.empty()) undeformed_polys.push_back(to_pixels(view, p0));
    auto p1 = cell_section<dim>(x1, axis, s);
    if (!p1.empty()) {
      deformed_polys.push_back(to_pixels(view, p1));
      magnitude.push_back(mag);
    }
  }
  for (const auto& p : undeformed_polys) draw_outline(canvas, p, colors::light_grey);
  for (std::size_t k = 0; k < deformed_polys.size(); ++k)
    if (deformed_polys[k].size() >= 3) canvas.fill_polygon(deformed_polys[k], viridis(range.t(magnitude[k])));
  for (const auto& p : deformed_polys) draw_outline(canvas, p, colors::black);
  draw_colorbar(canvas, view, view.y_offset + view.height + kMargin, range.lo, range.hi, caption);
  canvas.write_png(path);
  nlohmann::json j = {{"file", path.string()},
                      {"normal_axis", axis},
                      {"displacement_range", {0.0, umax}},
                      {"cut_elements", deformed_polys.size()},
                      {"pixels_per_unit", view.scale}};
  if (dim == 3) j["frame_coordinate"] = s;
  return j;
}

template std::array<SliceView, 2> mesh_figure_views<2>(const Image<2>&, int);
template std::array<SliceView, 2> mesh_figure_views<3>(const Image<3>&, int);
template nlohmann::json write_mesh_figures<2>(const OrientedImage<2>&, const MeshModel<2>&, const fs::path&,
                                              const Eigen::Matrix<double, 2, 1>*);
template nlohmann::json write_mesh_figures<3>(const OrientedImage<3>&, const MeshModel<3>&, const fs::path&,
                                              const Eigen::Matrix<double, 3, 1>*);
template nlohmann::json write_deformed_slice<2>(const MeshModel<2>&,
                                                const std::vector<Eigen::Matrix<double, 2, 1>>&,
                                                const fs::path&, const Eigen::Matrix<double, 2, 1>&, int,
                                                const std::string&);
template nlohmann::json write_deformed_slice<3>(const MeshModel<3>&,
                                                const std::vector<Eigen::Matrix<double, 3, 1>>&,
                                                const fs::path&, const Eigen::Matrix<double, 3, 1>&, int,
                                                const std::string&);

}  // namespace vim::pipeline

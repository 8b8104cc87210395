// figures/needle_path.png (figures.hpp): a needle's final shape and its tip's path in views normal to its
// planned line, with the targets, on png.hpp's canvas (the seed figure's projection panels).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vim/pipeline/output/figures.hpp>

namespace vim::pipeline {

namespace {

// The lateral directions of the views: 3D, the world x axis (y when the needle runs along x) made normal
// to the needle, and the needle × it; 2D, the normal of the needle.
template <int dim>
std::vector<Eigen::Matrix<double, dim, 1>> lateral_directions(const Eigen::Matrix<double, dim, 1>& axis) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  if constexpr (dim == 3) {
    const Vec start = std::abs(axis.x()) > 0.9 ? Vec::UnitY() : Vec::UnitX();
    const Vec e0 = (start - start.dot(axis) * axis).normalized();
    return {e0, axis.cross(e0)};
  } else {
    return {Vec(-axis.y(), axis.x())};
  }
}

void ring(Canvas& canvas, const Eigen::Vector2d& c, double radius, Rgb colour, bool filled) {
  std::vector<Eigen::Vector2d> pts;
  for (int k = 0; k < 32; ++k)
    pts.push_back(c + radius * Eigen::Vector2d(std::cos(k * M_PI / 16), std::sin(k * M_PI / 16)));
  if (filled)
    canvas.fill_polygon(pts, colour);
  else
    canvas.polyline_closed(pts, colour, 2);
}

}  // namespace

template <int dim>
nlohmann::json write_needle_path_figure(const std::filesystem::path& path,
                                        const Eigen::Matrix<double, dim, 1>& entry,
                                        const Eigen::Matrix<double, dim, 1>& axis,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& shape,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& tips,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& targets,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& moved_targets,
                                        const std::string& length_unit) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  if (shape.size() < 2 || tips.empty() || targets.size() != moved_targets.size())
    throw std::invalid_argument(
        "write_needle_path_figure: a shape of two points or more, a tip, and one moved position per target "
        "are required");
  constexpr int kMargin = 14, kTitle = 20, kPanel = 420;
  const Vec a = axis.normalized();
  const std::vector<Vec> lateral = lateral_directions<dim>(a);
  const auto along = [&](const Vec& x) { return (x - entry).dot(a); };
  // The depths spanned and the largest lateral offsets of the needle and of the targets.
  double u_lo = 0.0, u_hi = 0.0, deviation = 0.0, target_offset = 0.0;
  const auto offset = [&](const Vec& x) { return ((x - entry) - along(x) * a).norm(); };
  for (const auto* points : {&shape, &tips, &targets, &moved_targets})
    for (const Vec& x : *points) {
      u_lo = std::min(u_lo, along(x));
      u_hi = std::max(u_hi, along(x));
      if (points == &shape || points == &tips)
        deviation = std::max(deviation, offset(x));
      else
        target_offset = std::max(target_offset, offset(x));
    }
  const double span = std::max(u_hi - u_lo, 1e-9);
  const double pad = std::max(0.05 * span, 1e-3 * span + 1e-12);
  const double magnify = magnification(deviation, kPanel / (span + 2.0 * pad));
  const double half = std::max({0.15 * span, target_offset + pad, magnify * deviation + pad});
  const std::array<Eigen::Vector2d, 2> box{
      {Eigen::Vector2d(u_lo - pad, -half), Eigen::Vector2d(u_hi + pad, half)}};
  const std::vector<SliceView> views =
      projection_panels(std::vector<std::array<Eigen::Vector2d, 2>>(lateral.size(), box), kPanel, kMargin,
                        kMargin + kTitle, true);
  char legend[200];
  std::snprintf(
      legend, sizeof legend,
      "grey: planned line, black: needle, green: tip path (deflection x %g); blue ring: target, red: "
      "moved",
      magnify);
  const int width = std::max(views.front().width, Canvas::text_size(legend, 12)[0]) + 2 * kMargin;
  Canvas canvas(width, views.back().y_offset + views.back().height + kMargin + kTitle);
  nlohmann::json panels = nlohmann::json::array();
  for (std::size_t p = 0; p < views.size(); ++p) {
    const SliceView& view = views[p];
    const Vec& e = lateral[p];
    std::string direction;
    for (int d = 0; d < dim; ++d) {
      char c[32];
      std::snprintf(c, sizeof c, "%s%.3g", d ? ", " : "", std::abs(e[d]) < 1e-12 ? 0.0 : e[d]);
      direction += c;
    }
    const std::string caption =
        "depth along the planned line right, lateral (" + direction + ") down [" + length_unit + "]";
    draw_panel(canvas, view, caption, view.y_offset - kTitle + 2);
    // A point of the needle (its lateral offset magnified) or of a target (as it is), in pixels.
    const auto at = [&](const Vec& x, double m) {
      return view.to_pixel(along(x), m * (x - entry - along(x) * a).dot(e));
    };
    const Eigen::Vector2d base = view.to_pixel(std::min(along(shape.front()), 0.0), 0.0);
    const Eigen::Vector2d end = view.to_pixel(std::max(along(shape.back()), along(tips.back())), 0.0);
    canvas.line(base.x(), base.y(), end.x(), end.y(), colors::light_grey, 1);
    for (std::size_t k = 1; k < tips.size(); ++k) {
      const Eigen::Vector2d p0 = at(tips[k - 1], magnify), p1 = at(tips[k], magnify);
      canvas.line(p0.x(), p0.y(), p1.x(), p1.y(), kPathColour, 1);
    }
    for (std::size_t k = 1; k < shape.size(); ++k) {
      const Eigen::Vector2d p0 = at(shape[k - 1], magnify), p1 = at(shape[k], magnify);
      canvas.line(p0.x(), p0.y(), p1.x(), p1.y(), colors::black, 2);
    }
    for (std::size_t t = 0; t < targets.size(); ++t) {
      ring(canvas, at(targets[t], 1.0), 5.0, kPlannedSeed, false);
      ring(canvas, at(moved_targets[t], 1.0), 3.0, kFinalSeed, true);
    }
    nlohmann::json panel = panel_report(view);
    panel["lateral"] = std::vector<double>(e.data(), e.data() + dim);
    panels.push_back(panel);
  }
  canvas.text(kMargin, views.back().y_offset + views.back().height + kMargin, legend, colors::axis, 12);
  canvas.write_png(path);
  return {{"file", path.string()}, {"deviation_magnified", magnify}, {"panels", panels}};
}

#define VIM_NEEDLE_PATH_FIGURE(dim)                                                                         \
  template nlohmann::json write_needle_path_figure<dim>(                                                    \
      const std::filesystem::path&, const Eigen::Matrix<double, dim, 1>&,                                   \
      const Eigen::Matrix<double, dim, 1>&, const std::vector<Eigen::Matrix<double, dim, 1>>&,              \
      const std::vector<Eigen::Matrix<double, dim, 1>>&, const std::vector<Eigen::Matrix<double, dim, 1>>&, \
      const std::vector<Eigen::Matrix<double, dim, 1>>&, const std::string&);
VIM_NEEDLE_PATH_FIGURE(2)
VIM_NEEDLE_PATH_FIGURE(3)
#undef VIM_NEEDLE_PATH_FIGURE

}  // namespace vim::pipeline

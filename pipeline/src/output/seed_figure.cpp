// figures/seeds.png (figures.hpp): a procedure's planned and final seed positions in projections along
// the world axes, on png.hpp's canvas.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vim/pipeline/output/figures.hpp>

namespace vim::pipeline {

template <int dim>
nlohmann::json write_seed_figure(const std::filesystem::path& path,
                                 const std::vector<Eigen::Matrix<double, dim, 1>>& planned,
                                 const std::vector<Eigen::Matrix<double, dim, 1>>& final_position,
                                 const std::string& length_unit) {
  if (planned.empty() || planned.size() != final_position.size())
    throw std::invalid_argument("write_seed_figure: one final position per planned seed is required");
  constexpr int kMargin = 14, kTitle = 20, kPanel = 300, kRing = 5, kDot = 3;
  // Square panels over the cube around the seeds' bounding box (padded): one scale for all.
  Eigen::Matrix<double, dim, 1> lo = planned.front(), hi = lo;
  double largest_error = 0.0;
  for (std::size_t i = 0; i < planned.size(); ++i) {
    lo = lo.cwiseMin(planned[i]).cwiseMin(final_position[i]);
    hi = hi.cwiseMax(planned[i]).cwiseMax(final_position[i]);
    largest_error = std::max(largest_error, (final_position[i] - planned[i]).norm());
  }
  const double half = 0.5 * (hi - lo).maxCoeff() + std::max(0.1 * (hi - lo).maxCoeff(), 1.0);
  const Eigen::Matrix<double, dim, 1> centre = 0.5 * (lo + hi);
  lo = centre.array() - half;
  hi = centre.array() + half;
  std::vector<std::pair<int, int>> planes{{0, 1}};
  if constexpr (dim == 3) planes = {{0, 1}, {0, 2}, {1, 2}};
  std::vector<std::array<Eigen::Vector2d, 2>> boxes;
  for (const auto& [u, v] : planes)
    boxes.push_back({{Eigen::Vector2d(lo[u], lo[v]), Eigen::Vector2d(hi[u], hi[v])}});
  std::vector<SliceView> views = projection_panels(boxes, kPanel, kMargin, kMargin + kTitle);
  for (std::size_t p = 0; p < views.size(); ++p) {
    views[p].u = planes[p].first;
    views[p].v = planes[p].second;
  }
  const int x = views.back().x_offset + views.back().width + kMargin;
  const double scale = views.front().scale;
  const double magnify = magnification(largest_error, scale);
  const int height = views.front().height;
  Canvas canvas(x, kMargin + kTitle + height + kMargin + kTitle);
  const char* names = "xyz";
  nlohmann::json panels = nlohmann::json::array();
  for (const SliceView& view : views) {
    const int u = view.u, v = view.v;
    draw_panel(canvas, view, std::string(1, names[u]) + " right, " + names[v] + " down [" + length_unit + "]",
               kMargin);
    const auto at = [&](const Eigen::Matrix<double, dim, 1>& p) { return view.to_pixel(p[u], p[v]); };
    for (std::size_t i = 0; i < planned.size(); ++i) {
      const Eigen::Matrix<double, dim, 1> tip = planned[i] + magnify * (final_position[i] - planned[i]);
      const Eigen::Vector2d a = at(planned[i]), b = at(tip);
      canvas.line(a.x(), a.y(), b.x(), b.y(), colors::axis, 1);
    }
    for (const auto& p : planned) {
      const Eigen::Vector2d c = at(p);
      std::vector<Eigen::Vector2d> ring;
      for (int k = 0; k < 32; ++k)
        ring.push_back(c + kRing * Eigen::Vector2d(std::cos(k * M_PI / 16), std::sin(k * M_PI / 16)));
      canvas.polyline_closed(ring, kPlannedSeed, 2);
    }
    for (const auto& p : final_position) {
      const Eigen::Vector2d c = at(p);
      std::vector<Eigen::Vector2d> disk;
      for (int k = 0; k < 32; ++k)
        disk.push_back(c + kDot * Eigen::Vector2d(std::cos(k * M_PI / 16), std::sin(k * M_PI / 16)));
      canvas.fill_polygon(disk, kFinalSeed);
    }
    nlohmann::json panel = panel_report(view);
    panel["u"] = u;
    panel["v"] = v;
    panels.push_back(panel);
  }
  char legend[128];
  std::snprintf(legend, sizeof legend, "blue ring: planned seed, red dot: final seed, line: error x %g",
                magnify);
  canvas.text(kMargin, kMargin + kTitle + height + kMargin, legend, colors::axis, 12);
  canvas.write_png(path);
  return {
      {"file", path.string()}, {"seeds", planned.size()}, {"error_magnified", magnify}, {"panels", panels}};
}

template nlohmann::json write_seed_figure<2>(const std::filesystem::path&,
                                             const std::vector<Eigen::Vector2d>&,
                                             const std::vector<Eigen::Vector2d>&, const std::string&);
template nlohmann::json write_seed_figure<3>(const std::filesystem::path&,
                                             const std::vector<Eigen::Vector3d>&,
                                             const std::vector<Eigen::Vector3d>&, const std::string&);

}  // namespace vim::pipeline

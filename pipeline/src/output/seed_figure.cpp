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
  std::vector<SliceView> views;
  int x = kMargin;
  for (const auto& [u, v] : planes) {
    SliceView view = make_slice_view(-1, u, v, {lo[u], lo[v]}, {hi[u], hi[v]}, kPanel);
    view.x_offset = x;
    view.y_offset = kMargin + kTitle;
    x += view.width + kMargin;
    views.push_back(view);
  }
  const double scale = views.front().scale;
  // The errors drawn magnified by a power of 10 when the largest is under 10 pixels.
  double magnify = 1.0;
  while (largest_error > 0.0 && largest_error * scale * magnify < 10.0) magnify *= 10.0;
  const int height = views.front().height;
  Canvas canvas(x, kMargin + kTitle + height + kMargin + kTitle);
  const char* names = "xyz";
  nlohmann::json panels = nlohmann::json::array();
  for (const SliceView& view : views) {
    const int u = view.u, v = view.v;
    canvas.polyline_closed({{view.x_offset, view.y_offset},
                            {view.x_offset + view.width, view.y_offset},
                            {view.x_offset + view.width, view.y_offset + view.height},
                            {view.x_offset, view.y_offset + view.height}},
                           colors::light_grey);
    canvas.text(view.x_offset, kMargin,
                std::string(1, names[u]) + " right, " + names[v] + " down [" + length_unit + "]",
                colors::axis, 12);
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
    panels.push_back({{"u", u},
                      {"v", v},
                      {"u_min", view.u_min},
                      {"v_min", view.v_min},
                      {"scale", view.scale},
                      {"x_offset", view.x_offset},
                      {"y_offset", view.y_offset}});
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

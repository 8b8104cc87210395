// Figures people look at: image slices with the mesh cross-section (3D: three orthogonal
// slices, image + outlines beside the element means; 2D: the image with the mesh overlaid and the
// discretized image, like the paper's Figs. 4–6), the energy history (Fig. 9), simulation line plots
// and a deformed-mesh slice. Drawn in the image's axis-aligned frame (the mesher's coordinates), PNG.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/png.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

// Maps in-plane frame coordinates (u, v) of a slice to continuous canvas pixel coordinates: the
// pixel (i, j) covers [i, i+1) × [j, j+1). u grows to the right, v grows downwards (image rows).
struct SliceView {
  int axis = -1;                    // frame axis normal to the slice (-1 in 2D)
  int u = 0, v = 1;                 // in-plane frame axes
  double u_min = 0.0, v_min = 0.0;  // physical coordinates of the panel's top-left corner
  double scale = 1.0;               // pixels per physical unit (same on both axes: true aspect ratio)
  int x_offset = 0, y_offset = 0;   // panel position on the canvas
  int width = 0, height = 0;        // panel size in pixels

  Eigen::Vector2d to_pixel(double pu, double pv) const {
    return {x_offset + (pu - u_min) * scale, y_offset + (pv - v_min) * scale};
  }
  Eigen::Vector2d to_plane(double px, double py) const {
    return {u_min + (px - x_offset) / scale, v_min + (py - y_offset) / scale};
  }
};

// A panel for the rectangle [lo, hi] (in-plane frame coordinates) whose longer side has
// `max_pixels` pixels.
SliceView make_slice_view(int axis, int u, int v, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                          int max_pixels);

// Projection panels (the seed and needle-path figures): panel p shows the rectangle boxes[p] = {lo, hi}
// of its own in-plane coordinates (u right, v down), all at one scale (`panel_pixels` on the longest side
// of any box), side by side from (margin, top) `margin` apart, or `stacked` one under another with `top`
// between them (room for each panel's caption). Throws std::invalid_argument for an empty box.
std::vector<SliceView> projection_panels(const std::vector<std::array<Eigen::Vector2d, 2>>& boxes,
                                         int panel_pixels, int margin, int top, bool stacked = false);
// The power of 10 (≥ 1) by which a figure magnifies small offsets (the seeds' errors, the needle's
// deflection) so that the largest, `largest` units at `scale` pixels per unit, is at least 10 pixels.
inline double magnification(double largest, double scale) {
  double m = 1.0;
  while (largest > 0.0 && largest * scale * m < 10.0) m *= 10.0;
  return m;
}
// A projection panel's light grey frame, and its caption (12 px) at height caption_y.
void draw_panel(Canvas& canvas, const SliceView& view, const std::string& caption, int caption_y);
// A panel for report.json: u_min, v_min, scale (pixels per unit), x_offset, y_offset, width, height: a
// point (p_u, p_v) is at pixel (x_offset + (p_u − u_min)·scale, y_offset + (p_v − v_min)·scale).
nlohmann::json panel_report(const SliceView& view);

// Cross-section of a tetrahedron with the plane x[axis] = s, as in-plane (u, v) points ordered
// around the polygon (3 or 4 points; fewer when the plane only touches an edge or a vertex).
std::vector<Eigen::Vector2d> tet_slice_polygon(const std::array<Eigen::Vector3d, 4>& x, int axis, double s);

// The names of the three orthogonal slices by normal axis: sagittal (x), coronal (y), axial (z).
const char* slice_name(int axis);

// Panel layout used by write_mesh_figures (exposed so tests and other figures can find pixels):
// the left panel (image + red outlines) and the right panel (element means + black outlines).
template <int dim>
std::array<SliceView, 2> mesh_figure_views(const Image<dim>& image, int axis);

// 3D: DIR/figures/slice_{sagittal,coronal,axial}.png through slice_point (frame coordinates;
// default the image centre), each snapped to the nearest voxel-centre plane. 2D:
// DIR/figures/mesh_overlay.png and DIR/figures/discretized.png. Returns report.json's
// ["figures"]["mesh"]: the files, the slices and the pixel scale.
template <int dim>
nlohmann::json write_mesh_figures(const OrientedImage<dim>& image, const MeshModel<dim>& model,
                                  const std::filesystem::path& dir,
                                  const Eigen::Matrix<double, dim, 1>* slice_point = nullptr);

// Line chart with axes, ticks at 1-2-5 steps with their values, axis titles and a legend of `names`
// (none if empty). Non-finite values break a series. Returns {x_range, y_range, x_ticks, y_ticks,
// series, x_label, y_label, plot_area = [left, top, right, bottom] pixels} for report["figures"].
nlohmann::json write_line_plot(const std::filesystem::path& path, const std::vector<double>& x,
                               const std::vector<std::vector<double>>& series,
                               const std::vector<std::string>& names = {}, const std::string& x_label = "",
                               const std::string& y_label = "");

// Fig. 9: E, E_G/E_G0 and E_D/E_D0 against the iteration, each normalised to history[0].
nlohmann::json write_energy_plot(const std::vector<vim::IterationRecord>& history,
                                 const std::filesystem::path& path);

// The frame axis to which a slice through a needle's tip should be normal so that it holds as much of
// the needle as possible: the axis along which `direction` (frame) has its smallest component; ties go
// to the later axis (a needle along x or y is cut by the z slice, one along z by the y slice).
inline int slice_normal_along(const Eigen::Vector3d& direction) {
  int best = 2;
  for (int a = 1; a >= 0; --a)
    if (std::abs(direction[a]) < std::abs(direction[best])) best = a;
  return best;
}

// The mesh after displacement (per node, frame axes) cut by the plane x[normal_axis] =
// slice_point[normal_axis] in 3D (2D: the whole deformed mesh): undeformed outline in light grey,
// deformed elements filled by |u| (viridis) with black outlines, a colour bar labelled with its range
// and `caption`. Returns the ranges for the report.
template <int dim>
nlohmann::json write_deformed_slice(const MeshModel<dim>& model,
                                    const std::vector<Eigen::Matrix<double, dim, 1>>& displacement,
                                    const std::filesystem::path& path,
                                    const Eigen::Matrix<double, dim, 1>& slice_point,
                                    int normal_axis = dim - 1, const std::string& caption = "|u|");

// figures/seeds.png (seed_figure.cpp): a procedure's seeds in world coordinates, each planned position
// an open blue ring of radius 5 px and its final position a red disk of radius 3 px, with a dark line
// from the plan along the error, magnified by a power of 10 (`error_magnified`) when the largest error
// is under 10 px; 3D: three square projections side by side along the world axes (x–y, x–z, y–z), 2D:
// x–y, one scale for all (the cube around the seeds, padded). Returns per panel its axes, `u_min`,
// `v_min`, `scale` (pixels per unit) and `x_offset`, `y_offset`: a point (p_u, p_v) is at pixel
// (x_offset + (p_u − u_min)·scale, y_offset + (p_v − v_min)·scale).
template <int dim>
nlohmann::json write_seed_figure(const std::filesystem::path& path,
                                 const std::vector<Eigen::Matrix<double, dim, 1>>& planned,
                                 const std::vector<Eigen::Matrix<double, dim, 1>>& final_position,
                                 const std::string& length_unit);
inline constexpr Rgb kPlannedSeed{30, 80, 220};
inline constexpr Rgb kFinalSeed{220, 30, 30};

// figures/needle_path.png (needle_path_figure.cpp): a needle in views normal to its planned line (3D: two,
// the planes through the line along `lateral`[0] and [1]; 2D: one), depth along the line to the right and
// the lateral coordinate down, one scale for all: the planned line (light grey), the tip's path over the
// steps (`tips`, thin, kPathColour), the needle's final shape (`shape`, base to tip, 2 px, black), their
// deviations from the line magnified by a power of 10 (`deviation_magnified`) when the largest is under
// 10 px, and each target at rest (a kPlannedSeed ring) and where the tissue moved it (a kFinalSeed dot),
// at their true positions. Returns the file, the magnification and per panel panel_report() with its
// `lateral` direction (world): a point x is drawn at (u, v) = ((x − entry)·axis, m (x − entry)·lateral),
// m the magnification for the needle and 1 for the targets.
template <int dim>
nlohmann::json write_needle_path_figure(const std::filesystem::path& path,
                                        const Eigen::Matrix<double, dim, 1>& entry,
                                        const Eigen::Matrix<double, dim, 1>& axis,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& shape,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& tips,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& targets,
                                        const std::vector<Eigen::Matrix<double, dim, 1>>& moved_targets,
                                        const std::string& length_unit);
inline constexpr Rgb kPathColour{0, 150, 60};

}  // namespace vim::pipeline

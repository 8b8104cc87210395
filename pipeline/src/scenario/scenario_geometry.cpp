// The scenario against the image (scenario.hpp): needle entries, directions, depths and targets inside
// the image box (in the frame of an oblique image), and the needle paths in that frame.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/point_text.hpp>

namespace vim::pipeline {

namespace {

// The narrowest width of a box of the given extents perpendicular to the unit direction `axis`: the
// width along a unit p is sum_d |p_d| extent_d, and over the unit vectors p perpendicular to the axis it
// is smallest where some p_d = 0 (between those points it is a positive multiple of a cosine, which has
// no interior minimum), i.e. at p along axis x e_d in 3D; in 2D p is the one perpendicular.
template <int dim>
double width_across(const Eigen::Matrix<double, dim, 1>& axis, const Eigen::Matrix<double, dim, 1>& extent) {
  double width = std::numeric_limits<double>::infinity();
  if constexpr (dim == 2) {
    width = std::abs(axis[1]) * extent[0] + std::abs(axis[0]) * extent[1];
  } else {
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector3d p = axis.cross(Eigen::Vector3d::Unit(d));
      if (p.norm() > 1e-12) width = std::min(width, p.normalized().cwiseAbs().dot(extent));
    }
  }
  return width;
}

}  // namespace

template <int dim>
void check_scenario_geometry(const Scenario& s, const Eigen::Matrix<double, dim, 1>& box_min,
                             const Eigen::Matrix<double, dim, 1>& box_max, const WorldTransform<dim>& tf) {
  using V = Eigen::Matrix<double, dim, 1>;
  const double tol = 1e-6 * (box_max - box_min).norm();
  auto inside = [&](const V& p) {
    for (int d = 0; d < dim; ++d)
      if (p[d] < box_min[d] - tol || p[d] > box_max[d] + tol) return false;
    return true;
  };
  auto str = [](const V& w) {
    std::ostringstream o;
    o << "[";
    for (int d = 0; d < dim; ++d) o << (d ? ", " : "") << w[d];
    o << "]";
    return o.str();
  };
  // The image box in world coordinates, for the messages (its corners for a rotated image).
  V wlo = V::Constant(std::numeric_limits<double>::max()), whi = -wlo;
  for (int c = 0; c < (1 << dim); ++c) {
    V p;
    for (int d = 0; d < dim; ++d) p[d] = ((c >> d) & 1) ? box_max[d] : box_min[d];
    const V w = tf.to_world(p);
    wlo = wlo.cwiseMin(w);
    whi = whi.cwiseMax(w);
  }
  const bool oblique = !tf.direction.isIdentity(0.0);
  const std::string box =
      oblique ? "the image box (an oblique box: the world bounding box of its corners is " + str(wlo) +
                    " .. " + str(whi) + ", its centre " + str(tf.to_world(0.5 * (box_min + box_max))) + ")"
              : "the image box (world " + str(wlo) + " .. " + str(whi) + ")";
  // For an oblique image a point can lie inside the bounding box but outside the image: say where it
  // is along the image's own axes (the direction's columns, from voxel 0's centre).
  auto along_axes = [&](const V& frame) -> std::string {
    if (!oblique) return "";
    return "; along the image axes from voxel 0's centre it is at " + str(frame - tf.origin) +
           ", the box spans " + str(box_min - tf.origin) + " .. " + str(box_max - tf.origin);
  };
  for (std::size_t i = 0; i < s.needles.size(); ++i) {
    const auto& n = s.needles[i];
    const std::string p = s.needle_list ? "needles[" + std::to_string(i) + "]" : "needle";
    const V entry = tf.to_frame(spec_vector<dim>(n.entry));
    if (!inside(entry))
      throw ScenarioError(s.where(n.line) + p + ".entry " + str(spec_vector<dim>(n.entry)) + " is outside " +
                          box + along_axes(entry) + "; the entry must be inside the image or on its surface");
    const V dir = tf.vector_to_frame(spec_vector<dim>(n.direction));
    // Largest travel that stays in the box.
    double tmax = std::numeric_limits<double>::infinity();
    for (int d = 0; d < dim; ++d) {
      if (dir[d] > 1e-12) tmax = std::min(tmax, (box_max[d] - entry[d]) / dir[d]);
      if (dir[d] < -1e-12) tmax = std::min(tmax, (box_min[d] - entry[d]) / dir[d]);
    }
    if (!(tmax > tol))
      throw ScenarioError(s.where(n.line) + p + ".direction " + str(spec_vector<dim>(n.direction)) +
                          " points out of " + box + " at the entry " + str(spec_vector<dim>(n.entry)));
    if (n.depth > tmax + tol)
      throw ScenarioError(s.where(n.line) + p + ".depth = " + number_text(n.depth) +
                          " takes the tip out of " + box +
                          "; the largest depth from this entry along this direction is " + number_text(tmax));
    // A holder before the entry (needle.flexible.free_length > 0) is in the air: the needle's free part
    // must not run through the image, so the entry must be on the image's surface, facing the holder.
    if (n.flexible && n.flexible->free_length > 0.0) {
      double back = std::numeric_limits<double>::infinity();
      for (int d = 0; d < dim; ++d) {
        if (dir[d] < -1e-12) back = std::min(back, (box_max[d] - entry[d]) / -dir[d]);
        if (dir[d] > 1e-12) back = std::min(back, (box_min[d] - entry[d]) / -dir[d]);
      }
      if (back > tol)
        throw ScenarioError(s.where(n.flexible->line) + p + ".flexible.free_length = " +
                            number_text(n.flexible->free_length) + " puts the holder " +
                            number_text(n.flexible->free_length) + " before the entry " +
                            str(spec_vector<dim>(n.entry)) + ", but the needle's free part would run " +
                            number_text(std::min(back, n.flexible->free_length)) + " through " + box +
                            ", where it would have to touch tissue; with a holder before the entry, the "
                            "entry must lie on the image's surface (or use free_length: 0)");
    }
    const double width = width_across<dim>(dir, box_max - box_min);
    if (n.diameter > width)
      throw ScenarioError(
          s.where(n.line) + p + ".diameter = " + number_text(n.diameter) + " is larger than " + box +
          " across the needle (its narrowest width perpendicular to the needle's direction is " +
          number_text(width) + "); the needle must fit inside the image");
  }
  for (const auto& t : s.targets) {
    if (t.position.size() != static_cast<std::size_t>(dim))  // a label target not resolved by a run
      throw ScenarioError(s.where(t.line) + "target '" + t.name + "' {label: " + t.label +
                          "} needs a label image (--labels LABELS)");
    const V position = tf.to_frame(spec_vector<dim>(t.position));
    if (!inside(position))
      throw ScenarioError(s.where(t.line) + "target '" + t.name + "' position " +
                          str(spec_vector<dim>(t.position)) + " is outside " + box + along_axes(position));
  }
  // Geometric regions that cannot touch the box are caught later (selects no node), with the BC index.
}

template <int dim>
needle::NeedlePath<dim> needle_path(const NeedleSpec& n, const WorldTransform<dim>& tf) {
  Eigen::Matrix<double, dim, 1> entry, direction;
  for (int d = 0; d < dim; ++d) {
    entry[d] = n.entry[static_cast<std::size_t>(d)];
    direction[d] = n.direction[static_cast<std::size_t>(d)];
  }
  return {tf.to_frame(entry), tf.vector_to_frame(direction.normalized()).normalized(), n.depth};
}

template <int dim>
std::vector<needle::NeedlePath<dim>> needle_paths(const Scenario& s, const WorldTransform<dim>& tf) {
  std::vector<needle::NeedlePath<dim>> paths;
  for (const auto& n : s.needles) paths.push_back(needle_path<dim>(n, tf));
  return paths;
}

template <int dim>
std::optional<Image<dim>> needle_refinement_density(const Scenario& s, const Image<dim>& image,
                                                    const WorldTransform<dim>& tf) {
  if (!s.needle_refinement) return std::nullopt;
  return needle::needle_density<dim>(image, needle_paths<dim>(s, tf), s.needle_refinement->size_ratio,
                                     s.needle_refinement->radius);
}

template std::optional<Image<2>> needle_refinement_density<2>(const Scenario&, const Image<2>&,
                                                              const WorldTransform<2>&);
template std::optional<Image<3>> needle_refinement_density<3>(const Scenario&, const Image<3>&,
                                                              const WorldTransform<3>&);
template needle::NeedlePath<2> needle_path<2>(const NeedleSpec&, const WorldTransform<2>&);
template needle::NeedlePath<3> needle_path<3>(const NeedleSpec&, const WorldTransform<3>&);
template std::vector<needle::NeedlePath<2>> needle_paths<2>(const Scenario&, const WorldTransform<2>&);
template std::vector<needle::NeedlePath<3>> needle_paths<3>(const Scenario&, const WorldTransform<3>&);
template void check_scenario_geometry<2>(const Scenario&, const Eigen::Matrix<double, 2, 1>&,
                                         const Eigen::Matrix<double, 2, 1>&, const WorldTransform<2>&);
template void check_scenario_geometry<3>(const Scenario&, const Eigen::Matrix<double, 3, 1>&,
                                         const Eigen::Matrix<double, 3, 1>&, const WorldTransform<3>&);

}  // namespace vim::pipeline

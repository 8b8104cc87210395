// Label test images (a cube of voxels filled with one label) and the regular grids VIM starts from on
// them (tests only).
#pragma once

#include <array>
#include <vim/image.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim::test {

// n³ voxels of `spacing`, the box's corner at the origin, every voxel holding `fill`.
inline Image<3> cube_labels(long n, double spacing, float fill) {
  std::array<long, 3> size{{n, n, n}};
  std::array<double, 3> sp{{spacing, spacing, spacing}};
  std::array<double, 3> origin{{0.5 * spacing, 0.5 * spacing, 0.5 * spacing}};
  return Image<3>(size, sp, origin, fill);
}

// The regular grid of about `nodes` nodes over the image's box.
inline SimplexMesh<3> grid_of(const Image<3>& img, long nodes) {
  const auto n = nodes_per_axis_for_budget<3>(img.box_min(), img.box_max(), nodes);
  return regular_grid_mesh<3>(img.box_min(), img.box_max(), n);
}

}  // namespace vim::test

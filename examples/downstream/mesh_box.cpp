// The mesher alone, linked through pkg-config (vim-mesher: Eigen + TBB): meshes a sphere of value 2
// in a cube of value 1 (the paper's Table I phantom, 24³ voxels over [0, 3]³) with VIM and prints
// what any tiling of the box must satisfy.
//   mesh_box NODES
#include <algorithm>
#include <cstdio>
#include <string>
#include <vim/initial_mesh.hpp>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: mesh_box NODES\n");
    return 2;
  }
  constexpr long n = 24;
  const double h = 3.0 / n;
  vim::Image<3> image({{n, n, n}}, {{h, h, h}}, {{h / 2, h / 2, h / 2}}, 1.0f);
  for (std::size_t k = 0; k < image.voxel_count(); ++k)
    if ((image.point_of(image.index_of(k)) - Eigen::Vector3d(1.5, 1.5, 1.5)).norm() < 1.0)
      image.data[k] = 2.0f;

  const auto lo = image.box_min(), hi = image.box_max();
  vim::SimplexMesh<3> initial =
      vim::regular_grid_mesh<3>(lo, hi, vim::nodes_per_axis_for_budget<3>(lo, hi, std::stol(argv[1])));
  const vim::VimResult<3> r = vim::optimize<3>(image, std::move(initial), vim::VimOptions{});

  double volume = 0.0, max_dihedral = 0.0;
  long voxels = 0;
  for (std::size_t c = 0; c < r.mesh.n_cells(); ++c) {
    const auto x = vim::cell_points(r.mesh, c);
    volume += vim::signed_volume<3>(x);
    max_dihedral = std::max(max_dihedral, vim::max_dihedral_deg<3>(x));
    voxels += r.values[c].voxels;
  }
  std::printf("nodes %zu\nelements %zu\n", r.mesh.n_points(), r.mesh.n_cells());
  std::printf("volume %.17g\nvoxels %ld\nmax_dihedral %.17g\n", volume, voxels, max_dihedral);
  std::printf("energy_first %.17g\nenergy_last %.17g\n", r.history.front().energy, r.history.back().energy);
  return 0;
}

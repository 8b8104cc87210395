// Meshes an image with VIM through vim::mesher and simulates a needle insertion on that mesh through
// vim::pipeline: the library calls behind `vim-pipeline IMAGE --nodes NODES --simulate SCENARIO`
// (a scenario without a `mesh:` section), printing the numbers a study would keep.
//   mesh_and_simulate IMAGE SCENARIO NODES
#include <cstdio>
#include <exception>
#include <string>
#include <utility>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/version.hpp>
#include <vim/vim.hpp>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: mesh_and_simulate IMAGE SCENARIO NODES\n");
    return 2;
  }
  try {
    // Image (ITK through vim::pipeline), initial Kuhn grid with the node budget, VIM with the
    // paper's defaults (vim::VimOptions, as vim-pipeline's).
    const vim::pipeline::OrientedImage<3> image = vim::pipeline::read_image<3>(argv[1]);
    const auto lo = image.image.box_min(), hi = image.image.box_max();
    vim::SimplexMesh<3> initial =
        vim::regular_grid_mesh<3>(lo, hi, vim::nodes_per_axis_for_budget<3>(lo, hi, std::stol(argv[3])));
    vim::VimResult<3> meshed = vim::optimize<3>(image.image, std::move(initial), vim::VimOptions{});

    // The model in the image's frame, with the frame-to-world map, and the scenario on it.
    vim::pipeline::MeshModel<3> model;
    model.mesh = std::move(meshed.mesh);
    model.values = std::move(meshed.values);
    model.transform.origin = image.origin();
    model.transform.direction = image.direction;
    const vim::pipeline::Scenario scenario = vim::pipeline::read_scenario(argv[2], 3);
    vim::pipeline::SimulationOptions options;
    options.progress = false;
    const auto result = vim::pipeline::run_simulation<3>(model, scenario, options);
    const auto& needle = result.needles.front();

    std::printf("version %s\n", VIM_VERSION_STRING);
    std::printf("nodes %zu\nelements %zu\n", model.mesh.n_points(), model.mesh.n_cells());
    std::printf("iterations %zu\nenergy %.17g\n", meshed.history.size() - 1, meshed.history.back().energy);
    std::printf("steps %zu\ndepth %.17g\n", needle.depth.size() - 1, needle.depth.back());
    std::printf("axial_force %.17g\nlateral_force %.17g\n", needle.axial_force.back(),
                needle.lateral_force.back());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mesh_and_simulate: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

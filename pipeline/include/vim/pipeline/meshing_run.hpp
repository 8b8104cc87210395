// One run of vim-pipeline, stage by stage (docs/architecture.md): an image becomes a VIM mesh
// (Goksel & Salcudean, IEEE TMI 2011), optionally a needle-insertion simulation on it, and files.
//
//   read_inputs   image (header read once), sizing image, scenario checked against the image box
//   make_mesh     initial grid → VIM optimisation (§IV) or the grid itself, or one cell per voxel;
//                 segmentation (§VI-B); the world-coordinate grid, built once for every writer
//   build_model   the FEM model of the scenario on that mesh (simulation.hpp)
//   simulate      the needle insertion; its step files, needle.csv and figures
//   write_outputs mesh.vtu, the --export formats, the figures
//   write_report  report.json and the summary on stdout
//
// run() calls them in this order; a library user can call them one by one and read the state in
// between (model(), world_grid(), report()). Each stage lives in its own source file
// (pipeline/src/run_*.cpp).
#pragma once

#include <array>
#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>
#include <vim/pipeline/image_io.hpp>
#include <vim/pipeline/model.hpp>
#include <vim/pipeline/output_directory.hpp>
#include <vim/pipeline/run_options.hpp>
#include <vim/pipeline/scenario.hpp>
#include <vim/pipeline/simulation.hpp>
#include <vim/pipeline/vtk_output.hpp>

namespace vim::pipeline {

template <int dim>
class MeshingRun {
 public:
  // Reads the scenario (options.simulate) for this dimension, applies its mesh keys that the command
  // line does not set, and refuses a non-empty output folder: all before any work. `image` is the
  // input file whose header has been read (its dimension must be dim).
  MeshingRun(const RunOptions& options, ImageFile image);
  MeshingRun(const MeshingRun&) = delete;
  MeshingRun& operator=(const MeshingRun&) = delete;
  ~MeshingRun();

  // The whole run: the stages below in order; the output folder is complete when it returns.
  void run() {
    read_inputs();
    make_mesh();
    build_model();
    simulate();
    write_outputs();
    write_report();
  }

  void read_inputs();    // run_read_inputs.cpp
  void make_mesh();      // run_make_mesh.cpp
  void build_model();    // run_simulate.cpp (nothing without a scenario)
  void simulate();       // run_simulate.cpp (nothing without a scenario)
  void write_outputs();  // run_write_outputs.cpp
  void write_report();   // run_write_report.cpp; commits the output folder

  const RunOptions& options() const { return options_; }
  const std::optional<Scenario>& scenario() const { return scenario_; }
  const OrientedImage<dim>& image() const { return *image_; }
  const MeshModel<dim>& model() const { return model_; }  // simplex meshers; empty for voxel
  // The mesh in world coordinates (the voxel hexahedra for --mesher voxel), no fields: the geometry
  // of mesh.vtu and of every simulation step.
  const UnstructuredGrid& world_grid() const { return *world_grid_; }
  const nlohmann::json& report() const { return report_; }

 private:
  void warn(const std::string& stage, const std::string& message);
  void read_sizing_image();
  void check_scenario();
  void check_node_limit(const std::array<int, dim>& nodes_per_axis, double voxels) const;
  void optimize_mesh(SimplexMesh<dim> initial);
  void segment_mesh();
  UnstructuredGrid mesh_vtu_grid() const;
  void write_simulation_figures(const SimulationResult<dim>& result);

  std::optional<Scenario> scenario_;
  RunOptions options_;  // the command line's, with the scenario's mesh keys
  ImageFile image_file_;
  nlohmann::json report_;
  std::chrono::steady_clock::time_point start_;
  OutputDirectory out_;

  std::optional<OrientedImage<dim>> image_, sizing_;
  std::optional<Image<dim>> needle_density_;  // mesh.needle_refinement (§VI-E)
  MeshModel<dim> model_;
  std::array<int, dim> nodes_per_axis_{};
  std::vector<IterationRecord> energy_history_;
  SimplexMesh<dim> world_mesh_;  // model_.mesh in world coordinates (simplex meshers)
  std::shared_ptr<const UnstructuredGrid> world_grid_;
  std::unique_ptr<NeedleSimulation<dim>> simulation_;
  double simulate_seconds_ = 0.0;
};

}  // namespace vim::pipeline

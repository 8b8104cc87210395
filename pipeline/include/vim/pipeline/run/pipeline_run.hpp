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
// (pipeline/src/run/run_*.cpp) and returns what it produced (stage_results.hpp), which the run keeps;
// report.json is made from those once, at the end (report()). A library user with the inputs in memory (the
// Python module) gives them as RunInputs instead of files, and may reuse the mesh of another run
// (reuse_mesh).
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/common/output_directory.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/vtk_output.hpp>
#include <vim/pipeline/run/run_options.hpp>
#include <vim/pipeline/run/stage_results.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

namespace vim::pipeline {

// The inputs of a run held in memory, instead of the files options.image, options.sizing and
// options.simulate name (those strings then only name the inputs in messages and report.json).
template <int dim>
struct RunInputs {
  OrientedImage<dim> image;                  // checked by the caller as read_image checks a file
  std::optional<OrientedImage<dim>> sizing;  // a density image with the image's direction (§VI-E)
  // a label image beside `image` (options.labels names it; options.labels == options.image: `image` is
  // the label image itself)
  std::optional<OrientedImage<dim>> labels;
  std::optional<Scenario> scenario;   // read for this dimension; its mesh keys apply as the CLI's
  std::string tool = "vim-pipeline";  // report.json "tool" name
  bool keep_step_fields = false;      // SimulationResult keeps every step's displacements
  // Called after each iteration of the density-weighted initialisation ("sizing") and of VIM ("vim").
  std::function<void(const std::string& stage, const IterationRecord&)> on_iteration;
};

// Where a run stands among MPI ranks: not an option, set by the entry point (cli.cpp's run_on_ranks for
// one simulation over the ranks of mpirun; the default is one process).
struct RunRanks {
  // The ranks the simulation's FEM solves run over; more than 1: the step files are .pvtu with a .vtu
  // piece per rank, and the ranks other than 0 have no output folder (options.out empty).
  int size = 1;
  const void* comm = nullptr;  // with size > 1: the MPI_Comm* of those ranks (SimulationOptions::mpi_comm)
  // On the ranks other than 0: the --out folder, where the rank writes its pieces of the step files.
  std::filesystem::path pieces_out;
};

template <int dim>
class PipelineRun {
 public:
  // Reads the scenario (options.simulate) for this dimension, applies its mesh keys that the command
  // line does not set, and refuses a non-empty output folder: all before any work. `image` is the
  // input file whose header has been read (its dimension must be dim).
  PipelineRun(const RunOptions& options, ImageFile image, RunRanks ranks = {});
  // The same from memory; without options.out the run only meshes (and simulates without files: no
  // write stages).
  PipelineRun(const RunOptions& options, RunInputs<dim> inputs, RunRanks ranks = {});
  PipelineRun(const PipelineRun&) = delete;
  PipelineRun& operator=(const PipelineRun&) = delete;
  ~PipelineRun();

  // The whole run: the stages below in order; the output folder is complete when it returns.
  void run() {
    read_inputs();
    make_mesh();
    build_model();
    simulate();
    if (!out_) return;  // a rank other than 0 of a simulation over MPI ranks: rank 0 writes the files
    write_outputs();
    write_report();
  }

  const InputsResult& read_inputs();  // run_read_inputs.cpp
  const MeshResult& make_mesh();      // run_make_mesh.cpp
  // Instead of make_mesh: the mesh, energy history, meshing record and warnings of `meshed`, a run on
  // the same image that has made its mesh (a simplex mesher).
  const MeshResult& reuse_mesh(const PipelineRun& meshed);  // run_make_mesh.cpp
  void build_model();                                       // run_simulate.cpp (nothing without a scenario)
  const SimulateResult& simulate();                         // run_simulate.cpp (nothing without a scenario)
  const OutputsResult& write_outputs();                     // run_write_outputs.cpp
  const ReportResult& write_report();                       // run_write_report.cpp; commits the output folder

  const RunOptions& options() const { return options_; }
  const std::optional<Scenario>& scenario() const { return scenario_; }
  const OrientedImage<dim>& image() const { return *image_; }
  const MeshModel<dim>& model() const { return model_; }  // simplex meshers; empty for voxel
  // The mesh in world coordinates (the voxel hexahedra for --mesher voxel), no fields: the geometry
  // of mesh.vtu and of every simulation step.
  const UnstructuredGrid& world_grid() const { return *world_grid_; }
  // report.json as it stands: made from the stages' results (run_write_report.cpp); complete after
  // write_report.
  nlohmann::json report() const;
  // Every warning of the run so far, in the order given (report.json's "warnings").
  std::vector<std::string> warnings() const;
  // The energy history of make_mesh (entry 0 the initial mesh; the grid mesher has only that one).
  const std::vector<IterationRecord>& energy_history() const { return energy_history_; }
  // mesh.vtu: world_grid() with the per-element and per-node fields (run_write_outputs.cpp).
  UnstructuredGrid mesh_vtu_grid() const;
  // The result of simulate(), if it ran.
  const SimulationResult<dim>* simulation_result() const { return simulation_result_.get(); }

 private:
  void warn(std::vector<std::string>& warnings, const std::string& stage, const std::string& message);
  void read_sizing_image();
  void read_label_image();  // run_read_labels.cpp
  void check_scenario();
  void check_node_limit(const std::array<int, dim>& nodes_per_axis, double voxels) const;
  void optimize_mesh(SimplexMesh<dim> initial);
  void segment_mesh();
  nlohmann::json write_simulation_figures(const SimulationResult<dim>& result);
  OutputDirectory& out();

  std::optional<Scenario> scenario_;
  RunOptions options_;  // the command line's, with the scenario's mesh keys
  RunRanks ranks_;
  std::optional<ImageFile> image_file_;
  std::optional<RunInputs<dim>> inputs_;  // instead of image_file_
  std::chrono::steady_clock::time_point start_;
  // What the stages produced (stage_results.hpp).
  InputsResult inputs_result_;
  MeshResult mesh_result_;
  SimulateResult simulate_result_;
  OutputsResult outputs_result_;
  std::optional<ReportResult> report_result_;
  std::unique_ptr<OutputDirectory> out_;

  std::optional<OrientedImage<dim>> image_, sizing_;
  std::optional<Image<dim>> labels_;          // --labels in IMAGE's grid
  std::optional<Image<dim>> needle_density_;  // mesh.needle_refinement (§VI-E)
  MeshModel<dim> model_;
  std::array<int, dim> nodes_per_axis_{};
  std::vector<IterationRecord> energy_history_;
  SimplexMesh<dim> world_mesh_;  // model_.mesh in world coordinates (simplex meshers)
  std::shared_ptr<const UnstructuredGrid> world_grid_;
  std::unique_ptr<NeedleSimulation<dim>> simulation_;
  std::unique_ptr<const SimulationResult<dim>> simulation_result_;
};

}  // namespace vim::pipeline

// What each stage of a PipelineRun (pipeline_run.hpp) produced, returned by the stage and kept by the
// run. report.json is made from these once, at the end (PipelineRun::report, run_write_report.cpp);
// the comments name each field's key there.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/run_options.hpp>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

// read_inputs: the images as report.json describes them and the density of mesh.needle_refinement.
struct InputsResult {
  nlohmann::json image;                  // "input": image_json of IMAGE
  std::optional<nlohmann::json> sizing;  // "sizing": image_json of the --sizing image as read
  std::optional<nlohmann::json> labels;  // "labels": the --labels file, alone or not, the labels it holds
  struct NeedleRefinement {
    double size_ratio = 0.0, radius = 0.0;
    double peak_density = 0.0;  // size_ratio^-(dim + 2)
  };
  std::optional<NeedleRefinement> needle_refinement;  // "needle_refinement" (--mesher vim only)
  std::vector<StageTime> timing;                      // read_image
  std::vector<std::string> warnings;
};

// "optimization": VIM's record, or for the grid mesher the fixed grid's energies as iteration 0.
struct OptimizationRecord {
  int iterations = 0;
  bool converged = false;
  double eg0 = 0.0, ed0 = 0.0;
  std::vector<IterationRecord> history;
};

// "segmentation" (--threshold): the components of the elements above it and the largest, the object.
struct SegmentationRecord {
  double threshold = 0.0;
  int components = 0;
  long object_elements = 0;
  double object_volume = 0.0;
  long object_voxels = 0;
};

// "labels" of "mesh" (--labels, docs/labels.md): per label its elements (by the majority rule), their
// volume, the label's voxel volume and its misclassified volume (its voxels whose centre lies in an
// element of another label, times the voxel volume).
struct LabelRecord {
  int label = 0;
  std::string name;
  long elements = 0;
  double volume = 0.0, voxel_volume = 0.0, misclassified_volume = 0.0;
};

// make_mesh, or reuse_mesh from the run that made the mesh.
struct MeshResult {
  MesherKind mesher = MesherKind::vim;  // "mesh": mesher, nodes, elements, nodes_per_axis, quality
  std::size_t nodes = 0, elements = 0;
  std::vector<int> nodes_per_axis;     // simplex meshers
  std::optional<MeshQuality> quality;  // simplex meshers
  std::optional<OptimizationRecord> optimization;
  std::optional<SegmentationRecord> segmentation;
  std::vector<LabelRecord> labels;
  std::vector<StageTime>
      timing;  // voxel_grid; or initial_mesh, voxel_statistics or sizing and optimize, segment
  std::vector<std::string> warnings;
};

// build_model and simulate (a run with a scenario).
struct SimulateResult {
  nlohmann::json simulation;                          // "simulation": the simulation's own entry
  nlohmann::json figures = nlohmann::json::object();  // "figures"/"simulation": per needle, or static_load
  double seconds = 0.0;                               // "timing"/"simulate": build_model and simulate
  std::vector<std::string> warnings;
};

// write_outputs.
struct OutputsResult {
  std::optional<nlohmann::json> exports;        // "exports" (file paths relative to the output folder)
  std::optional<nlohmann::json> mesh_figures;   // "figures"/"mesh"
  std::optional<nlohmann::json> energy_figure;  // "figures"/"energy"
  std::vector<StageTime> timing;                // write
  std::vector<std::string> warnings;
};

// write_report.
struct ReportResult {
  double total_seconds = 0.0;        // "timing"/"total"
  std::vector<std::string> outputs;  // "outputs": every file of the output folder, report.json included
};

}  // namespace vim::pipeline

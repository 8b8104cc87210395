// The options of one vim-pipeline run (RunOptions), as the command line sets them and every stage of
// PipelineRun (pipeline_run.hpp) reads them; defaults are those of --help.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/scenario/mesh_options.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

enum class MesherKind { vim, grid, voxel };

// The mesher table: --mesher NAME (its check, help and value) and report.json's mesh.mesher read it.
struct Mesher {
  MesherKind kind;
  std::string name;  // --mesher value
  std::string help;  // --mesher's help: "NAME = help"
};
const std::vector<Mesher>& meshers();
std::string to_string(MesherKind m);
// The kind of a --mesher name; std::nullopt for an unknown one.
std::optional<MesherKind> mesher_kind(const std::string& name);

// Every command-line option, with its default, and nothing else: the meshing options and their defaults
// are the MeshOptions it extends; where a run stands among MPI ranks is its RunRanks (pipeline_run.hpp).
// The stages (meshing, simulation, exports, figures) read what they need from here.
struct RunOptions : MeshOptions {
  std::string image;          // input image (positional)
  std::filesystem::path out;  // --out DIR
  bool info = false;          // --info: print the image's header and statistics, no meshing

  // Meshing, besides MeshOptions
  std::string sizing;  // --sizing IMAGE (density for the E_G-only initialisation)
  // --labels LABELS: a label image (docs/labels.md) meshed by the label energy; beside IMAGE (resampled
  // into its grid) or alone (then `image` names the same file and the label table gives the moduli).
  std::string labels;
  std::vector<std::string> label_moduli;  // --label-modulus LABEL=E, repeatable (the label table)
  bool labels_alone() const { return !labels.empty() && labels == image; }
  std::optional<double> threshold;  // --threshold T: segment element means > T
  MesherKind mesher = MesherKind::vim;
  double max_memory = 0.0;  // --max-memory in bytes (0 = the memory available to the process)

  // Simulation and outputs
  std::string simulate;    // --simulate SCENARIO.yaml ("" = mesh only)
  std::string study;       // --study STUDY.yaml: many scenarios (study.hpp) instead of --simulate
  std::string fit_forces;  // --fit-forces MEASURED.csv: fit the needle to it first (fit/fit_run.hpp)
  std::vector<std::string> exports = export_formats();  // --export: every format (mesh.vtu is always written)
  bool overwrite = false;
  bool compare_linear = false;  // --compare-linear: a static load case solved by both material models
  Verbosity verbosity = Verbosity::normal;

  std::vector<std::string> command_line;  // argv, for the report
};

}  // namespace vim::pipeline

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

// Every command-line option, with its default, and nothing else (where a run stands among MPI ranks is
// its RunRanks, pipeline_run.hpp). The stages (meshing, simulation, exports, figures) read what they
// need from here.
struct RunOptions {
  std::string image;          // input image (positional)
  std::filesystem::path out;  // --out DIR
  bool info = false;          // --info: print the image's header and statistics, no meshing

  // Meshing
  long nodes = 1000;     // --nodes: node budget of the initial regular grid
  double spacing = 0.0;  // --spacing: initial grid edge length in image units (0 = use --nodes)
  double lambda = VimOptions{}.lambda;
  double max_dihedral_deg = VimOptions{}.max_dihedral_deg;
  double min_dihedral_deg = 0.0;  // --min-dihedral: optional lower bound (0 = off)
  double min_radius_ratio = 0.0;  // --min-radius-ratio: optional d·r_in/R_circ lower bound (0 = off)
  int max_iterations = VimOptions{}.max_iterations;
  double convergence = VimOptions{}.convergence;  // --convergence: Eq. 9 threshold on v
  double energy_convergence =
      VimOptions{}.energy_convergence;  // --energy-convergence: and E falling less than this per iteration
  int search_width = VimOptions{}.search_width;  // --search-width: 0 = every direction searched in full
  int threads = 0;                               // 0 = all cores (TBB default)
  std::uint64_t seed = 1;
  bool check_invariants = kCheckedBuild;  // --check-invariants (on by default in a VIM_CHECKED build)
  std::string sizing;                     // --sizing IMAGE (density for the E_G-only initialisation)
  std::optional<double> threshold;        // --threshold T: segment element means > T
  MesherKind mesher = MesherKind::vim;
  double max_memory = 0.0;  // --max-memory in bytes (0 = the memory available to the process)

  // Simulation and outputs
  int degree = 1;          // --degree: FEM polynomial degree (1 = P1, the paper's model; 2 = P2)
  std::string simulate;    // --simulate SCENARIO.yaml ("" = mesh only)
  std::string study;       // --study STUDY.yaml: many scenarios (study.hpp) instead of --simulate
  std::string fit_forces;  // --fit-forces MEASURED.csv: fit the needle to it first (fit/fit_run.hpp)
  std::vector<std::string> exports = export_formats();  // --export: every format (mesh.vtu is always written)
  bool overwrite = false;
  Verbosity verbosity = Verbosity::normal;

  std::vector<std::string> command_line;  // argv, for the report

  // The mesher's options (threads, seed, λ, quality bound, iterations) taken from this struct.
  VimOptions vim_options() const;
};

}  // namespace vim::pipeline

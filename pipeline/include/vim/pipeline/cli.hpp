// The vim-pipeline command line: options (RunOptions, read by every stage), the output directory
// (refuses a non-empty DIR, removes what a failed run wrote), and the run driver
//   read image → initial mesh → VIM (mesher/) → segmentation → [simulation] → writers → report.
#pragma once

#include <vim/pipeline/progress.hpp>
#include <vim/vim.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace vim::pipeline {

enum class MesherKind { vim, grid, voxel };
std::string to_string(MesherKind m);

// Every command-line option, with its default. Stages added by other modules (simulation, exports,
// figures) read what they need from here.
struct RunOptions {
  std::string image;                 // input image (positional)
  std::filesystem::path out;         // --out DIR
  bool info = false;                 // --info: print the image's header and statistics, no meshing

  // Meshing
  long nodes = 1000;                 // --nodes: node budget of the initial regular grid
  double spacing = 0.0;              // --spacing: initial grid edge length in image units (0 = use --nodes)
  double lambda = VimOptions{}.lambda;
  double max_dihedral_deg = VimOptions{}.max_dihedral_deg;
  double min_dihedral_deg = 0.0;      // --min-dihedral: optional lower bound (0 = off)
  double min_radius_ratio = 0.0;      // --min-radius-ratio: optional d·r_in/R_circ lower bound (0 = off)
  int max_iterations = VimOptions{}.max_iterations;
  double convergence = VimOptions{}.convergence;                // --convergence: Eq. 9 threshold on v
  double energy_convergence = VimOptions{}.energy_convergence;  // --energy-convergence: and E falling less than this per iteration
  int search_width = VimOptions{}.search_width;  // --search-width: 0 = the paper's full search
  int threads = 0;                   // 0 = all cores (TBB default)
  std::uint64_t seed = 1;
  bool check_invariants = kCheckedBuild;  // --check-invariants (on by default in a VIM_CHECKED build)
  std::string sizing;                // --sizing IMAGE (density for the E_G-only initialisation)
  std::optional<double> threshold;   // --threshold T: segment element means > T
  MesherKind mesher = MesherKind::vim;

  // Simulation and outputs
  int degree = 1;                    // --degree: FEM polynomial degree (1 = P1, the paper's model; 2 = P2)
  std::string simulate;              // --simulate SCENARIO.yaml ("" = mesh only)
  std::vector<std::string> exports = {"vtk", "feb", "msh", "inp"};  // --export (mesh.vtu is always written)
  bool overwrite = false;
  Verbosity verbosity = Verbosity::normal;

  std::vector<std::string> command_line;  // argv, for the report

  // The mesher's options (threads, seed, λ, quality bound, iterations) taken from this struct.
  VimOptions vim_options() const;
};

// The output folder of one run. Files are registered before they are written so a failed run can
// remove exactly what it created (and the folder itself if this run created it and it is empty).
class OutputDirectory {
 public:
  // Throws InputError if `dir` exists, is not empty and overwrite is false (message names DIR), if it
  // exists and is not a directory, or if it cannot be created (a parent is a file, or not writable) —
  // before any work, although DIR itself is only created by the first file.
  OutputDirectory(std::filesystem::path dir, bool overwrite);
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory& operator=(const OutputDirectory&) = delete;
  ~OutputDirectory();

  // Creates DIR (and parents) on first use, creates the parent folders of `relative`
  // (e.g. "steps/step_0001.vtu"), records it, and returns the absolute path to write to.
  std::filesystem::path file(const std::string& relative);
  const std::filesystem::path& path() const { return dir_; }
  const std::vector<std::string>& files() const { return relative_; }

  // Call once everything is written; otherwise the destructor removes the registered files, and, if
  // they replaced files of an earlier run (--overwrite), that run's report.json, which would describe
  // files that are gone or no longer its own.
  void commit() { committed_ = true; }

 private:
  void create();
  std::filesystem::path dir_;
  bool created_dir_ = false, ready_ = false, committed_ = false, replaced_ = false;
  std::vector<std::filesystem::path> created_subdirs_;
  std::vector<std::string> relative_;
};

// Parses argv into options. Returns std::nullopt and sets `exit_code` when the program should stop
// (help/version: 0 after printing; usage error: 2 after one `vim-pipeline: error:` line).
std::optional<RunOptions> parse_command_line(int argc, char** argv, int& exit_code);

// Runs a parsed command. Returns the exit code; prints `vim-pipeline: error: ...` (one line) and
// returns 1 on InputError / std::invalid_argument / other failures, leaving DIR without partial files.
int run(const RunOptions& options);

// parse_command_line + run: the whole program (main.cpp calls this).
int main_cli(int argc, char** argv);

}  // namespace vim::pipeline

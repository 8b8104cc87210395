// The vim-pipeline command line (cli.hpp): the options and their checks, then PipelineRun
// (pipeline_run.hpp) for the image's dimension; errors become one line on stderr and an exit code.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vim/invariants.hpp>
#include <vim/pipeline/app/cli.hpp>
#include <vim/pipeline/common/memory_limit.hpp>
#include <vim/pipeline/fit/fit_run.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/pipeline/study/study.hpp>
#include <vim/version.hpp>

#include "run/run_support.hpp"
#include "study/study_ranks.hpp"

namespace vim::pipeline {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Command line

namespace {

// A real number in an interval; `closed_lo` includes lo ([lo, hi) instead of (lo, hi)).
// The whole of `s` as a number (std::stod accepts "nan", "inf"); false if it is not one.
bool parse_number(const std::string& s, double& v) {
  try {
    std::size_t pos = 0;
    v = std::stod(s, &pos);
    return pos == s.size();
  } catch (...) {
    return false;
  }
}

CLI::Validator number_in(double lo, double hi, bool closed_lo) {
  std::ostringstream d;
  d << "in " << (closed_lo ? "[" : "(") << lo << ", " << hi << ")";
  const std::string desc = d.str();
  return CLI::Validator(
      [lo, hi, closed_lo, desc](std::string& s) -> std::string {
        double v = 0;
        if (!parse_number(s, v)) return "value " + s + " is not a number";
        const bool above = closed_lo ? v >= lo : v > lo;
        return (above && v < hi) ? std::string() : "value " + s + " not " + desc;
      },
      desc);
}

// A finite number (NaN and ±inf are refused: a NaN threshold or spacing would silently mean "off");
// positive: also > 0.
CLI::Validator finite_number(bool positive) {
  const std::string desc = positive ? "POSITIVE" : "FINITE";
  return CLI::Validator(
      [positive](std::string& s) -> std::string {
        double v = 0;
        if (!parse_number(s, v)) return "value " + s + " is not a number";
        if (!std::isfinite(v)) return "value " + s + " is not a finite number";
        if (positive && !(v > 0.0)) return "value " + s + " is not > 0";
        return std::string();
      },
      desc);
}

// A byte count with an optional k/M/G/T suffix (parse_memory_size), replaced by the plain number.
CLI::Validator memory_size() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        const auto bytes = parse_memory_size(s);
        if (!bytes) return "value " + s + " is not a memory size > 0 such as 512M, 8G or 1000000";
        std::ostringstream v;
        v.precision(17);
        v << *bytes;
        s = v.str();
        return std::string();
      },
      "SIZE");
}

CLI::Validator half_open_unit() { return number_in(0.0, 1.0, true); }
CLI::Validator open_interval(double lo, double hi) { return number_in(lo, hi, false); }

const char* kFooter =
    R"(Outputs (in DIR; all in world coordinates, every file written under a temporary name):
  mesh.vtu     the mesh (image direction applied); cell data mean, variance, voxels, quality (3D: max
               dihedral angle, 2D: min angle, degrees), youngs_modulus with --simulate, with
               --threshold also segment and object; point data boundary (box faces a node lies on)
%EXPORTS%
  figures/     PNG: image slices beside the mesh cross-section, energy history; with --simulate
               force and target displacement vs depth and the deformed mesh at the last step
  simulation.pvd, steps/step_NNNN.vtu, needle.csv   with --simulate (open the .pvd in ParaView)
  report.json  input, options, mesh counts and quality, energy history, simulation, timings (README)
  with --study: cases/NAME/ (a --simulate run per case, and its case.yaml) and study.csv (a row per case)
  A non-empty DIR is refused unless --overwrite; a failed run removes the files it wrote.

Exit status: 0 success, 1 bad input or failure (one 'vim-pipeline: error:' line), 2 usage error.

Examples:
  vim-make-phantom table1 table1.mha
  vim-pipeline --info table1.mha
  vim-pipeline table1.mha --nodes 343 --threshold 1.5 --out out/table1
  vim-pipeline table1.mha --nodes 343 --mesher grid --out out/table1-grid
  vim-make-phantom prostate prostate.mha
  vim-pipeline prostate.mha --nodes 1000 --lambda 0.3 --out out/prostate
  vim-pipeline prostate.mha --nodes 1000 --simulate examples/prostate_needle.yaml --out out/needle
  mpirun -np 4 vim-pipeline prostate.mha --simulate examples/prostate_needle.yaml --out out/needle4
  vim-pipeline prostate.mha --study examples/prostate_study.yaml --out out/study
  mpirun -np 4 vim-pipeline prostate.mha --study examples/prostate_study.yaml --out out/study
)";

// The --help footer: kFooter with the export table's files in place of %EXPORTS%.
std::string footer() {
  std::string files = "  ", readers;
  for (const auto& row : export_table()) {
    files += (files.size() > 2 ? " mesh." : "mesh.") + row.name;
    readers += (readers.empty() ? "" : ", ") + row.reader;
  }
  std::string text = kFooter;
  return text.replace(text.find("%EXPORTS%"), 9, files + "\n               exports (--export): " + readers);
}

// --export's help: each format of the export table with its tool.
std::string export_help() {
  std::string list, names;
  for (const auto& row : export_table()) {
    list += row.name + " (" + row.option_help + "), ";
    names += (names.empty() ? "" : ",") + row.name;
  }
  return "Extra mesh formats, comma-separated: " + list + "all, or none alone (default: all = " + names +
         "; mesh.vtu is always written)";
}

// The options of the VIM mesher (--nodes ... --threshold), with their defaults and ranges.
void add_mesh_options(CLI::App& app, RunOptions& o) {
  const MeshOptions d;
  auto* nodes = app.add_option("-n,--nodes", o.nodes,
                               "Node budget of the initial regular grid (default " + std::to_string(d.nodes) +
                                   "; range [4, 10^8]; a 3D image needs >= 8); per-axis counts follow the "
                                   "box's aspect ratio")
                    ->type_name("N")
                    ->check(CLI::Range(4L, 100000000L));
  app.add_option("--spacing", o.spacing,
                 "Initial grid edge length in image units, instead of --nodes (default: off; > 0)")
      ->type_name("MM")
      ->check(finite_number(true))
      ->excludes(nodes);
  app.add_option("--lambda", o.lambda,
                 fmt("Weight of the image term in E = (1-λ)E_G/E_G0 + λE_D/E_D0 (default %g; range [0, 1); "
                     "0 = purely geometric)",
                     d.lambda))
      ->type_name("L")
      ->check(half_open_unit());
  app.add_option("--max-dihedral", o.max_dihedral_deg,
                 "Quality bound: largest dihedral angle in 3D / interior angle in 2D, degrees (default " +
                     std::to_string(static_cast<int>(d.max_dihedral_deg)) + "; range (90, 180))")
      ->type_name("DEG")
      ->check(open_interval(90.0, 180.0));
  app.add_option("--min-dihedral", o.min_dihedral_deg,
                 "Optional quality bound: smallest dihedral angle in 3D / interior angle in 2D, degrees; VIM "
                 "then makes no element below it (slivers; the regular grid starts at 45) (default 0 = off; "
                 "range [0, 60))")
      ->type_name("DEG")
      ->check(number_in(0.0, 60.0, true));
  app.add_option("--min-radius-ratio", o.min_radius_ratio,
                 "Optional quality bound: smallest normalised radius ratio d*r_in/R_circ (1 = regular "
                 "simplex) (default 0 = off; range [0, 1))")
      ->type_name("R")
      ->check(half_open_unit());
  app.add_option("--max-iterations", o.max_iterations,
                 "Cap on VIM iterations (default " + std::to_string(d.max_iterations) +
                     "; range [0, 100000]); the run stops earlier when it converges (--convergence)")
      ->type_name("K")
      ->check(CLI::Range(0, 100000));
  app.add_option(
         "--convergence", o.convergence,
         fmt("Stop when the RMS node move of an iteration over the bounding-box diagonal (v, Eq. 9) is "
             "below this and E has settled (--energy-convergence) (default %g, the paper's; range (0, 1))",
             d.convergence))
      ->type_name("V")
      ->check(open_interval(0.0, 1.0));
  app.add_option(
         "--energy-convergence", o.energy_convergence,
         fmt("Convergence also needs the iteration to lower E by less than this fraction (default %g; range "
             "[0, 1); 0 = "
             "Eq. 9 alone, the paper's rule, which can stop after one iteration when most nodes lie in "
             "uniform regions)",
             d.energy_convergence))
      ->type_name("R")
      ->check(half_open_unit());
  app.add_option("--search-width", o.search_width,
                 "Node update: probe every line-search direction at two points and search only the W best "
                 "in full; 0 = search every direction in full (about 2.4x slower, about the same fit; the "
                 "directions are the project's, not the paper's) "
                 "(default " +
                     std::to_string(d.search_width) + "; range [0, 1000])")
      ->type_name("W")
      ->check(CLI::Range(0, 1000));
  app.add_option("--threads", o.threads,
                 "Worker threads (default 0 = all cores; range [0, 1024]); results do not depend on it")
      ->type_name("T")
      ->check(CLI::Range(0, 1024));
  app.add_option("--seed", o.seed,
                 "Seed of the mesher's random-walk node strategy (library option VimOptions::strategy); the "
                 "line search the CLI runs is deterministic and does not use it (default 1; >= 0)")
      ->type_name("S");
  app.add_flag("--check-invariants", o.check_invariants,
               "Check every mesh invariant (no inverted element, quality bound, conforming tiling, boundary "
               "nodes on the box, caches, E never rising) after each VIM stage; about doubles meshing time "
               "(default off; on in a VIM_CHECKED build)");
  app.add_option(
         "--sizing", o.sizing,
         "Sizing/density image (same dimension as IMAGE, values > 0; larger = denser) for an "
         "E_G-only initialisation (paper §VI-E) of at most --max-iterations iterations (default: none)")
      ->type_name("IMAGE");
  app.add_option("--max-memory", o.max_memory,
                 "Refuse to mesh when the estimated peak memory exceeds this many bytes; suffixes k, M, G, T "
                 "(powers of 1024), e.g. 8G (default: the memory available to the process, cgroup limit "
                 "included)")
      ->type_name("SIZE")
      ->transform(memory_size());
  app.add_option("--threshold", o.threshold,
                 "Segment elements whose mean value is > T into face-connected components; the largest "
                 "by volume is the object (paper §VI-B) (default: off; unit of the image values)")
      ->type_name("T")
      ->check(finite_number(false));
}

// --labels and its label table (docs/labels.md).
void add_label_options(CLI::App& app, RunOptions& o) {
  app.add_option(
         "--labels", o.labels,
         "Label image (integers: a segmentation) meshed by the label energy, every label's boundary "
         "followed (docs/labels.md); beside IMAGE (resampled nearest-neighbour into its grid) or alone "
         "(IMAGE omitted; the label table gives the moduli); with --mesher voxel beside IMAGE, for label "
         "regions and targets only (default: none)")
      ->type_name("LABELS");
  app.add_option("--label-modulus", o.label_moduli,
                 "Young's modulus of one label, LABEL=E (repeatable; over the scenario's labels: table); "
                 "with --labels alone every label needs one")
      ->type_name("LABEL=E");
}

}  // namespace

std::optional<RunOptions> parse_command_line(int argc, char** argv, int& exit_code) {
  RunOptions o;
  for (int i = 0; i < argc; ++i) o.command_line.emplace_back(argv[i]);

  CLI::App app{
      "vim-pipeline: Image-based Variational Meshing (Goksel & Salcudean, IEEE TMI 2011) of a 2D/3D\n"
      "image (e.g. an elastogram of Young's modulus), optionally followed by a needle-insertion FEM\n"
      "simulation. Lengths are in the image's unit (mm for the shipped phantoms), values in its\n"
      "value unit (kPa for elastograms).",
      "vim-pipeline"};
  app.get_formatter()->column_width(34);
  app.footer(footer());
  app.set_version_flag("--version", std::string("vim-pipeline ") + VIM_VERSION_STRING);

  app.add_option("image", o.image,
                 "Input image: MetaImage (.mha/.mhd), NRRD (.nrrd/.nhdr) or NIfTI (.nii/.nii.gz); 2D or 3D, "
                 "scalar, any pixel type (read as float)")
      ->type_name("IMAGE");
  app.add_option("-o,--out", o.out, "Output directory (required unless --info); must be empty or new")
      ->type_name("DIR");
  app.add_flag("--info", o.info,
               "Print the image's size, spacing, extent, direction and value statistics, then exit");

  add_mesh_options(app, o);
  add_label_options(app, o);
  std::string mesher = to_string(o.mesher), mesher_help, mesher_names;
  std::vector<std::string> mesher_values;
  for (const Mesher& row : meshers()) {
    mesher_help += (mesher_help.empty() ? "" : "; ") + row.name + " = " + row.help;
    mesher_names += (mesher_names.empty() ? "" : "|") + row.name;
    mesher_values.push_back(row.name);
  }
  app.add_option("--mesher", mesher, mesher_help + " (default " + mesher + ")")
      ->type_name(mesher_names)
      ->check(CLI::IsMember(mesher_values));
  app.add_option("--degree", o.degree,
                 "FEM polynomial degree for --simulate: 1 = linear (the paper's model), 2 = quadratic "
                 "(avoids locking for ν near 0.5) (default 1; range {1, 2})")
      ->type_name("1|2")
      ->check(CLI::Range(1, 2));
  auto* simulate =
      app.add_option("--simulate", o.simulate,
                     "Needle-insertion scenario (YAML) to simulate on the mesh (default: mesh only)")
          ->type_name("SCENARIO.yaml");
  app.add_option("--study", o.study,
                 "A study (YAML): a base scenario run once per case of a list and/or grid of varied values; "
                 "DIR/cases/NAME/ per case and DIR/study.csv; resumes an earlier run in DIR; under mpirun "
                 "case i runs on rank i mod N (README, Studies)")
      ->type_name("STUDY.yaml")
      ->excludes(simulate)
      ->excludes("--sizing");
  app.add_option("--fit-forces", o.fit_forces,
                 "A measured insertion (CSV with columns depth, force in the scenario's units): fit the "
                 "needle's cutting forces and friction limits to it (DIR/fit.json, DIR/fitted.yaml, "
                 "DIR/figures/force_fit.png), then simulate the fitted scenario")
      ->type_name("MEASURED.csv")
      ->needs(simulate)
      ->excludes("--study");
  std::vector<std::string> export_values = export_formats();
  export_values.insert(export_values.end(), {"all", "none"});
  app.add_option("--export", o.exports, export_help())
      ->type_name("LIST")
      ->delimiter(',')
      ->check(CLI::IsMember(export_values));
  app.add_flag("--compare-linear", o.compare_linear,
               "Solve the scenario with the linear and the neo-Hookean material and report the relative "
               "difference |linear - neo-Hookean| / |neo-Hookean| (report.json simulation.compare_linear): "
               "a static load case per target and per displacement condition's reaction, a needle per "
               "target and for the axial force at each step")
      ->needs(simulate);
  app.add_flag("--overwrite", o.overwrite, "Write into a non-empty DIR, replacing files of the same name");
  bool quiet = false, verbose = false;
  auto* q = app.add_flag("-q,--quiet", quiet, "Only errors on stderr, no summary on stdout");
  app.add_flag("-v,--verbose", verbose, "More progress detail on stderr")->excludes(q);

  try {
    app.parse(argc, argv);
    if (o.image.empty() && o.labels.empty()) throw CLI::RequiredError("image");
    if (o.image.empty()) o.image = o.labels;  // the label image alone (RunOptions::labels_alone)
    if (!o.info && o.out.empty()) throw CLI::RequiredError("--out");
    if (std::find(o.exports.begin(), o.exports.end(), "none") != o.exports.end() && o.exports.size() > 1)
      throw CLI::ValidationError("--export", "none cannot be combined with other formats (got " +
                                                 CLI::detail::join(o.exports, ",") + ")");
  } catch (const CLI::CallForHelp& e) {
    exit_code = app.exit(e);
    return std::nullopt;
  } catch (const CLI::CallForAllHelp& e) {
    exit_code = app.exit(e);
    return std::nullopt;
  } catch (const CLI::CallForVersion& e) {
    exit_code = app.exit(e);
    return std::nullopt;
  } catch (const CLI::ParseError& e) {
    std::string msg = e.what();
    for (char& c : msg)
      if (c == '\n') c = ' ';
    std::cerr << "vim-pipeline: error: " << msg << " (see vim-pipeline --help)\n";
    exit_code = 2;
    return std::nullopt;
  }
  o.mesher = *mesher_kind(mesher);
  if (std::find(o.exports.begin(), o.exports.end(), "none") != o.exports.end()) o.exports.clear();
  if (std::find(o.exports.begin(), o.exports.end(), "all") != o.exports.end()) o.exports = export_formats();
  o.verbosity = quiet ? Verbosity::quiet : verbose ? Verbosity::verbose : Verbosity::normal;
  exit_code = 0;
  return o;
}

// ---------------------------------------------------------------------------------------------
// The run

namespace {

int run_info(const RunOptions& o) {
  const ImageFile file(o.image);
  const int d = file.dimension();
  json j = d == 2 ? image_json(file.read<2>(), o.image) : image_json(file.read<3>(), o.image);
  std::cout << o.image << " (" << d << "D)\n";
  print_image_info(std::cout, j);
  return 0;
}

}  // namespace

namespace {

// The message print_error shows for the exception a run ended with ("" if `work` succeeds).
std::string error_of_run(const std::function<void()>& work) {
  try {
    work();
    return "";
  } catch (const InvariantViolation& e) {
    return std::string("internal error, please report it with the input: ") + e.what();
  } catch (const std::bad_alloc&) {
    return "out of memory (try a smaller image or fewer --nodes)";
  } catch (const std::exception& e) {
    const std::string m = e.what();
    return m.empty() ? "unknown error" : m;
  }
}

void run_image(const RunOptions& o, const RunRanks& ranks = {}) {
  ImageFile image(o.image);
  if (image.dimension() == 2)
    PipelineRun<2>(o, std::move(image), ranks).run();
  else
    PipelineRun<3>(o, std::move(image), ranks).run();
}

// One simulation over the ranks of mpirun: every rank meshes and builds the model alike (the mesher is
// deterministic), the FEM solves run over the ranks (fem::distribute_solves), and rank 0 alone writes
// the output folder and prints progress.
int run_on_ranks(const RunOptions& o) {
  std::optional<StudyRanks> ranks;
  const std::string error = error_of_run([&] { ranks.emplace(); });
  if (!error.empty()) {
    print_error(error);
    return 1;
  }
  RunOptions mine = o;
  RunRanks run_ranks{ranks->size(), ranks->world(), {}};
  if (ranks->rank() != 0) {
    run_ranks.pieces_out = mine.out;
    mine.out.clear();
    mine.verbosity = Verbosity::quiet;
    Log::set_verbosity(Verbosity::quiet);
  }
  return ranks->finish(error_of_run([&] { run_image(mine, run_ranks); }));
}

}  // namespace

int run(const RunOptions& o) {
  Log::set_verbosity(o.verbosity);
  if (refused_on_many_ranks(o)) return 1;
  if (!o.study.empty()) return run_study(o);  // prints its errors itself (once under mpirun)
  if (launcher_ranks().size > 1) return run_on_ranks(o);
  const std::string error = error_of_run([&] {
    if (o.info)
      run_info(o);
    else if (!o.fit_forces.empty())
      run_force_fit(o);
    else
      run_image(o);
  });
  if (error.empty()) return 0;
  print_error(error);
  return 1;
}

int main_cli(int argc, char** argv) {
  int code = 0;
  const auto options = parse_command_line(argc, argv, code);
  if (!options) return code;
  return run(*options);
}

}  // namespace vim::pipeline

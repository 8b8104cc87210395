// The vim-pipeline command line (see cli.hpp). run_dim<dim>() shows the run order:
//   read_image → initial mesh → VIM optimisation (or grid / voxel) → segmentation
//   → [simulation] → mesh.vtu → [exports, figures] → report.json → summary.
// Other stages plug in at the call sites marked "PLUG-IN".
#include <vim/pipeline/cli.hpp>

#include <vim/initial_mesh.hpp>
#include <vim/invariants.hpp>
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/exports.hpp>
#include <vim/pipeline/figures.hpp>
#include <vim/pipeline/image_io.hpp>
#include <vim/pipeline/model.hpp>
#include <vim/pipeline/report.hpp>
#include <vim/pipeline/scenario.hpp>
#include <vim/pipeline/simulation.hpp>
#include <vim/pipeline/vtk_output.hpp>
#include <vim/quality.hpp>
#include <vim/segmentation.hpp>
#include <vim/sizing.hpp>
#include <vim/version.hpp>
#include <vim/voxel_statistics.hpp>
#include <vim/energy.hpp>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <cstdarg>
#include <cstdio>
#include <iostream>
#include <sstream>

#include <unistd.h>

namespace vim::pipeline {

namespace fs = std::filesystem;
using nlohmann::json;

std::string to_string(MesherKind m) {
  switch (m) {
    case MesherKind::vim: return "vim";
    case MesherKind::grid: return "grid";
    case MesherKind::voxel: return "voxel";
  }
  return "?";
}

VimOptions RunOptions::vim_options() const {
  VimOptions v;
  v.lambda = lambda;
  v.max_dihedral_deg = max_dihedral_deg;
  v.min_dihedral_deg = min_dihedral_deg;
  v.min_radius_ratio = min_radius_ratio;
  v.max_iterations = max_iterations;
  v.convergence = convergence;
  v.energy_convergence = energy_convergence;
  v.search_width = search_width;
  v.threads = threads;
  v.seed = seed;
  v.check_invariants = check_invariants;
  return v;
}

// ---------------------------------------------------------------------------------------------
// OutputDirectory

OutputDirectory::OutputDirectory(fs::path dir, bool overwrite) : dir_(std::move(dir)) {
  std::error_code ec;
  if (dir_.empty()) throw InputError("--out: no output directory given");
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec))
      throw InputError("--out " + dir_.string() + ": exists and is not a directory");
    if (!overwrite && !fs::is_empty(dir_, ec))
      throw InputError("--out " + dir_.string() +
                       ": output directory is not empty; choose a new or empty directory, or pass --overwrite");
  } else {
    // DIR is made by the first file, after the work: check now that it can be.
    fs::path ancestor = fs::absolute(dir_, ec).parent_path();
    while (!ancestor.empty() && !fs::exists(ancestor, ec) && ancestor != ancestor.parent_path()) ancestor = ancestor.parent_path();
    if (fs::exists(ancestor, ec) && !fs::is_directory(ancestor, ec))
      throw InputError("--out " + dir_.string() + ": cannot be created: " + ancestor.string() + " is not a directory");
    if (fs::is_directory(ancestor, ec) && ::access(ancestor.c_str(), W_OK) != 0)
      throw InputError("--out " + dir_.string() + ": cannot be created: " + ancestor.string() + " is not writable");
  }
}

void OutputDirectory::create() {
  if (ready_) return;
  std::error_code ec;
  if (!fs::exists(dir_, ec)) {
    if (!fs::create_directories(dir_, ec) || ec)
      throw InputError("--out " + dir_.string() + ": cannot create the directory (" + ec.message() + ")");
    created_dir_ = true;
  }
  ready_ = true;
}

fs::path OutputDirectory::file(const std::string& relative) {
  create();
  const fs::path p = dir_ / relative;
  // Create intermediate folders (e.g. steps/, figures/), remembering those this run made.
  std::vector<fs::path> missing;
  for (fs::path d = p.parent_path(); d != dir_ && !d.empty() && !fs::exists(d); d = d.parent_path())
    missing.push_back(d);
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    fs::create_directory(*it);
    created_subdirs_.push_back(*it);
  }
  if (std::find(relative_.begin(), relative_.end(), relative) == relative_.end()) {
    std::error_code ec;
    replaced_ = replaced_ || fs::exists(p, ec);  // a file of an earlier run (--overwrite)
    relative_.push_back(relative);
  }
  return p;
}

OutputDirectory::~OutputDirectory() {
  if (committed_ || !ready_) return;
  std::error_code ec;
  for (const auto& r : relative_) fs::remove(dir_ / r, ec);
  if (replaced_) fs::remove(dir_ / "report.json", ec);  // it lists files that are gone or not its own
  for (auto it = created_subdirs_.rbegin(); it != created_subdirs_.rend(); ++it)
    if (fs::is_empty(*it, ec)) fs::remove(*it, ec);
  if (created_dir_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
}

// ---------------------------------------------------------------------------------------------
// Command line

namespace {

std::string fmt(const char* f, ...) __attribute__((format(printf, 1, 2)));

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

CLI::Validator half_open_unit() { return number_in(0.0, 1.0, true); }
CLI::Validator open_interval(double lo, double hi) { return number_in(lo, hi, false); }

const char* kFooter = R"(Outputs (in DIR; all in world coordinates, every file written under a temporary name):
  mesh.vtu     the mesh (image direction applied); cell data mean, variance, voxels, quality (3D: max
               dihedral angle, 2D: min angle, degrees), youngs_modulus with --simulate, with
               --threshold also segment and object; point data boundary (box faces a node lies on)
  mesh.vtk mesh.feb mesh.msh mesh.inp
               exports (--export): deal.II GridIn (legacy 3.0, MaterialID), FEBio, Gmsh 4.1, Abaqus
  figures/     PNG: image slices beside the mesh cross-section, energy history; with --simulate
               force and target displacement vs depth and the deformed mesh at the last step
  simulation.pvd, steps/step_NNNN.vtu, needle.csv   with --simulate (open the .pvd in ParaView)
  report.json  input, options, mesh counts and quality, energy history, simulation, timings (README)
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
)";

}  // namespace

std::optional<RunOptions> parse_command_line(int argc, char** argv, int& exit_code) {
  RunOptions o;
  for (int i = 0; i < argc; ++i) o.command_line.emplace_back(argv[i]);
  const VimOptions d;

  CLI::App app{
      "vim-pipeline: Image-based Variational Meshing (Goksel & Salcudean, IEEE TMI 2011) of a 2D/3D\n"
      "image (e.g. an elastogram of Young's modulus), optionally followed by a needle-insertion FEM\n"
      "simulation. Lengths are in the image's unit (mm for the shipped phantoms), values in its\n"
      "value unit (kPa for elastograms).",
      "vim-pipeline"};
  app.get_formatter()->column_width(34);
  app.footer(kFooter);
  app.set_version_flag("--version", std::string("vim-pipeline ") + VIM_VERSION_STRING);

  app.add_option("image", o.image,
                 "Input image: MetaImage (.mha/.mhd), NRRD (.nrrd/.nhdr) or NIfTI (.nii/.nii.gz); 2D or 3D, "
                 "scalar, any pixel type (read as float)")
      ->type_name("IMAGE")
      ->required();
  app.add_option("-o,--out", o.out, "Output directory (required unless --info); must be empty or new")
      ->type_name("DIR");
  app.add_flag("--info", o.info, "Print the image's size, spacing, extent, direction and value statistics, then exit");

  auto* nodes = app.add_option("-n,--nodes", o.nodes,
                               "Node budget of the initial regular grid (default 1000; range [4, 10^8]; "
                               "a 3D image needs >= 8); per-axis counts follow the box's aspect ratio")
                    ->type_name("N")
                    ->check(CLI::Range(4L, 100000000L));
  app.add_option("--spacing", o.spacing,
                 "Initial grid edge length in image units, instead of --nodes (default: off; > 0)")
      ->type_name("MM")
      ->check(finite_number(true))
      ->excludes(nodes);
  app.add_option("--lambda", o.lambda,
                 fmt("Weight of the image term in E = (1-λ)E_G/E_G0 + λE_D/E_D0 (default %g; range [0, 1); "
                     "0 = purely geometric)", d.lambda))
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
  app.add_option("--convergence", o.convergence,
                 fmt("Stop when the RMS node move of an iteration over the bounding-box diagonal (v, Eq. 9) is "
                     "below this and E has settled (--energy-convergence) (default %g, the paper's; range (0, 1))",
                     d.convergence))
      ->type_name("V")
      ->check(open_interval(0.0, 1.0));
  app.add_option("--energy-convergence", o.energy_convergence,
                 fmt("Convergence also needs the iteration to lower E by less than this fraction (default %g; range [0, 1); 0 = "
                     "Eq. 9 alone, the paper's rule, which can stop after one iteration when most nodes lie in "
                     "uniform regions)", d.energy_convergence))
      ->type_name("R")
      ->check(half_open_unit());
  app.add_option("--search-width", o.search_width,
                 "Node update: probe every line-search direction at two points and search only the W best "
                 "in full; 0 = search every direction, as in the paper (slower, about the same fit) "
                 "(default " + std::to_string(d.search_width) + "; range [0, 1000])")
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
  app.add_option("--sizing", o.sizing,
                 "Sizing/density image (same dimension as IMAGE, values > 0; larger = denser) for an "
                 "E_G-only initialisation (paper §VI-E) of at most --max-iterations iterations (default: none)")
      ->type_name("IMAGE");
  app.add_option("--threshold", o.threshold,
                 "Segment elements whose mean value is > T into face-connected components; the largest "
                 "by volume is the object (paper §VI-B) (default: off; unit of the image values)")
      ->type_name("T")
      ->check(finite_number(false));
  std::string mesher = "vim";
  app.add_option("--mesher", mesher,
                 "vim = VIM optimisation; grid = the unoptimised initial grid with the same nodes; voxel = "
                 "one cell per voxel (fine reference) (default vim)")
      ->type_name("vim|grid|voxel")
      ->check(CLI::IsMember({"vim", "grid", "voxel"}));
  app.add_option("--degree", o.degree,
                 "FEM polynomial degree for --simulate: 1 = linear (the paper's model), 2 = quadratic "
                 "(avoids locking for ν near 0.5) (default 1; range {1, 2})")
      ->type_name("1|2")
      ->check(CLI::Range(1, 2));
  app.add_option("--simulate", o.simulate,
                 "Needle-insertion scenario (YAML) to simulate on the mesh (default: mesh only)")
      ->type_name("SCENARIO.yaml");
  app.add_option("--export", o.exports,
                 "Extra mesh formats, comma-separated: vtk (legacy, deal.II GridIn), feb (FEBio), msh "
                 "(Gmsh 4.1), inp (Abaqus), all, or none alone (default: all = vtk,feb,msh,inp; mesh.vtu is "
                 "always written)")
      ->type_name("LIST")
      ->delimiter(',')
      ->check(CLI::IsMember({"vtk", "feb", "msh", "inp", "all", "none"}));
  app.add_flag("--overwrite", o.overwrite, "Write into a non-empty DIR, replacing files of the same name");
  bool quiet = false, verbose = false;
  auto* q = app.add_flag("-q,--quiet", quiet, "Only errors on stderr, no summary on stdout");
  app.add_flag("-v,--verbose", verbose, "More progress detail on stderr")->excludes(q);

  try {
    app.parse(argc, argv);
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
  o.mesher = mesher == "grid" ? MesherKind::grid : mesher == "voxel" ? MesherKind::voxel : MesherKind::vim;
  if (std::find(o.exports.begin(), o.exports.end(), "none") != o.exports.end()) o.exports.clear();
  if (std::find(o.exports.begin(), o.exports.end(), "all") != o.exports.end()) o.exports = export_formats();
  o.verbosity = quiet ? Verbosity::quiet : verbose ? Verbosity::verbose : Verbosity::normal;
  exit_code = 0;
  return o;
}

// ---------------------------------------------------------------------------------------------
// The run

namespace {

json options_json(const RunOptions& o) {
  json j;
  // --spacing sets the initial grid instead of the node budget (the voxel reference uses neither).
  j["nodes"] = o.spacing > 0.0 ? json(nullptr) : json(o.nodes);
  j["spacing"] = o.spacing;
  j["lambda"] = o.lambda;
  j["max_dihedral_deg"] = o.max_dihedral_deg;
  j["min_dihedral_deg"] = o.min_dihedral_deg;
  j["min_radius_ratio"] = o.min_radius_ratio;
  j["max_iterations"] = o.max_iterations;
  j["convergence"] = o.convergence;
  j["energy_convergence"] = o.energy_convergence;
  j["search_width"] = o.search_width;
  j["threads"] = o.threads;
  j["seed"] = o.seed;
  j["check_invariants"] = o.check_invariants;
  j["sizing"] = o.sizing.empty() ? json(nullptr) : json(o.sizing);
  j["threshold"] = o.threshold ? json(*o.threshold) : json(nullptr);
  j["mesher"] = to_string(o.mesher);
  j["degree"] = o.degree;
  j["simulate"] = o.simulate.empty() ? json(nullptr) : json(o.simulate);
  j["export"] = o.exports;
  j["overwrite"] = o.overwrite;
  return j;
}

std::string fmt(const char* f, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, f);
  std::vsnprintf(buf, sizeof buf, f, ap);
  va_end(ap);
  return buf;
}

template <int dim>
void check_meshable(const OrientedImage<dim>& img, const std::string& file) {
  for (int a = 0; a < dim; ++a)
    if (img.image.size[a] < 2) {
      std::string sz;
      for (int b = 0; b < dim; ++b) sz += (b ? " x " : "") + std::to_string(img.image.size[b]);
      throw InputError(file + ": image is 1 voxel thick along axis " + std::to_string(a) + " (size " + sz +
                       "); meshing needs at least 2 voxels per axis (store a single slice as a 2D image)");
    }
}

// Per-element values of a fixed mesh (the grid mesher) and its energies, as history[0].
template <int dim>
void evaluate_fixed_mesh(const Image<dim>& image, MeshModel<dim>& model, const VimOptions& vo, json& report) {
  const VoxelStatistics<dim> stats(image);
  model.values.resize(model.mesh.n_cells());
  double eg = 0.0, ed = 0.0;
  for (std::size_t c = 0; c < model.mesh.n_cells(); ++c) {
    const auto x = cell_points(model.mesh, c);
    model.values[c] = stats.value(x);
    eg += geometric_energy<dim>(x);
    ed += discretization_energy(std::abs(signed_volume<dim>(x)), model.values[c].variance);
  }
  IterationRecord r;
  r.geometric = eg;
  r.discretization = ed;
  r.energy = EnergyNormalization{eg, ed, vo.lambda}.combined(eg, ed);
  report["optimization"] = {{"iterations", 0}, {"converged", false}, {"eg0", eg}, {"ed0", ed},
                            {"history", history_json({r})}};
}

// mesh-only output for --mesher voxel: one quad/hexahedron per voxel, value = voxel value.
template <int dim>
UnstructuredGrid voxel_grid(const OrientedImage<dim>& img) {
  const Image<dim>& im = img.image;
  UnstructuredGrid g;
  g.vtk_cell_type = dim == 3 ? 12 : 9;
  g.nodes_per_cell = 1 << dim;
  std::array<long, dim> np{};
  std::size_t n_points = 1;
  for (int a = 0; a < dim; ++a) n_points *= static_cast<std::size_t>(np[a] = im.size[a] + 1);
  g.points.reserve(n_points);
  for (std::size_t k = 0; k < n_points; ++k) {
    std::size_t r = k;
    Eigen::Matrix<double, dim, 1> p;
    for (int a = 0; a < dim; ++a) {
      p[a] = im.origin[a] + (static_cast<double>(r % np[a]) - 0.5) * im.spacing[a];
      r /= np[a];
    }
    const auto w = img.to_world(p);
    std::array<double, 3> q{};
    for (int a = 0; a < dim; ++a) q[a] = w[a];
    g.points.push_back(q);
  }
  // VTK corner order: quad (0,0),(1,0),(1,1),(0,1); hexahedron the same on z=0 then z=1 (reversed
  // in-plane under a mirroring direction, so the world cells stay positively oriented).
  const auto order2 = voxel_corner_order(img.direction.determinant() < 0.0);
  Field value{1, {}};
  value.values.reserve(im.voxel_count());
  for (std::size_t k = 0; k < im.voxel_count(); ++k) {
    const auto idx = im.index_of(k);
    for (int z = 0; z < (dim == 3 ? 2 : 1); ++z)
      for (const auto& c : order2) {
        long id = 0, stride = 1;
        for (int a = 0; a < dim; ++a) {
          const long off = a == 0 ? c[0] : a == 1 ? c[1] : z;
          id += (idx[a] + off) * stride;
          stride *= np[a];
        }
        g.connectivity.push_back(id);
      }
    value.values.push_back(im.data[k]);
  }
  g.cell_data["value"] = std::move(value);
  return g;
}

// Poisson ratio from which a degree-1 simulation warns about volumetric locking.
constexpr double kLockingPoisson = 0.4;

// A warning of the run: on stderr (unless --quiet) and in report.json "warnings".
void warn(json& report, const std::string& stage, const std::string& message) {
  Log::warning(stage, message);
  report["warnings"].push_back(message);
}

// Scenario mesh keys (nodes, lambda, degree, min_dihedral) apply unless the option was given on the command line.
RunOptions with_scenario_mesh(const RunOptions& given, const Scenario& sc) {
  auto on_command_line = [&](const std::string& flag) {
    for (const auto& a : given.command_line)
      if (a == flag || a.rfind(flag + "=", 0) == 0) return true;
    return false;
  };
  RunOptions o = given;
  if (sc.nodes && !on_command_line("--nodes") && !on_command_line("--spacing")) o.nodes = *sc.nodes;
  if (sc.lambda && !on_command_line("--lambda")) o.lambda = *sc.lambda;
  if (sc.degree && !on_command_line("--degree")) o.degree = static_cast<int>(*sc.degree);
  if (sc.min_dihedral && !on_command_line("--min-dihedral")) o.min_dihedral_deg = *sc.min_dihedral;
  return o;
}

// Figures of a needle run: axial/lateral force against depth for every needle and, on a simplex
// model, the deformed mesh at the last step cut through the final tip position.
template <int dim>
void write_simulation_figures(const SimulationResult<dim>& result, const MeshModel<dim>* model, OutputDirectory& out,
                              json& report) {
  // Axis titles in the scenario's units: force = modulus × length² (kPa·mm² = mN).
  std::string length = "mm", modulus = "kPa";
  if (result.report.contains("units")) {
    length = result.report["units"].value("length", length);
    modulus = result.report["units"].value("modulus", modulus);
  }
  const std::string force = length == "mm" && modulus == "kPa" ? "mN" : modulus + "·" + length + "²";
  for (const auto& run : result.needles) {
    if (run.depth.empty()) continue;
    const std::string prefix = result.needles.size() > 1 ? run.name + "_" : "";
    json& fig = report["figures"]["simulation"][run.name.empty() ? std::string("needle") : run.name];
    fig["force"] = write_line_plot(out.file("figures/" + prefix + "needle_force.png"), run.depth,
                                   {run.axial_force, run.lateral_force}, {"axial force", "lateral force"},
                                   "needle depth [" + length + "]", "force on the needle [" + force + "]");
    fig["force"]["file"] = "figures/" + prefix + "needle_force.png";
    if (!run.target_displacement.empty() && !run.target_displacement.front().empty()) {
      std::vector<std::vector<double>> series(run.target_displacement.front().size());
      for (const auto& step : run.target_displacement)
        for (std::size_t t = 0; t < step.size() && t < series.size(); ++t) series[t].push_back(step[t].norm());
      std::vector<std::string> names;
      for (std::size_t t = 0; t < series.size(); ++t)
        names.push_back(t < result.target_names.size() ? result.target_names[t] : "target " + std::to_string(t + 1));
      fig["targets"] = write_line_plot(out.file("figures/" + prefix + "target_displacement.png"), run.depth, series,
                                       names, "needle depth [" + length + "]", "target displacement |u| [" + length + "]");
      fig["targets"]["file"] = "figures/" + prefix + "target_displacement.png";
    }
    if (model && !run.vertex_displacement.empty() && run.vertex_displacement.back().size() == model->mesh.n_points()) {
      std::vector<Eigen::Matrix<double, dim, 1>> u;
      u.reserve(model->mesh.n_points());
      for (const auto& w : run.vertex_displacement.back()) u.push_back(model->transform.vector_to_frame(w));
      const Eigen::Matrix<double, dim, 1> tip = model->transform.to_frame(run.tip.back());
      int normal = dim - 1;  // 3D: the slice through the tip that holds the most of the needle
      if constexpr (dim == 3) normal = slice_normal_along(model->transform.vector_to_frame(run.axis));
      fig["deformed"] = write_deformed_slice<dim>(*model, u, out.file("figures/" + prefix + "deformed.png"), tip,
                                                  normal, "|u| [" + length + "]");
      fig["deformed"]["file"] = "figures/" + prefix + "deformed.png";
    }
  }
}

template <int dim>
int run_dim(const RunOptions& given) {
  // The scenario is read and checked before anything is written.
  std::optional<Scenario> scenario;
  if (!given.simulate.empty()) scenario = read_scenario(given.simulate, dim);
  const RunOptions o = scenario ? with_scenario_mesh(given, *scenario) : given;
  json report;
  report["tool"] = {{"name", "vim-pipeline"}, {"version", VIM_VERSION_STRING}};
  report["command_line"] = o.command_line;
  report["options"] = options_json(o);
  report["out"] = o.out.string();
  const auto t_total = std::chrono::steady_clock::now();

  OutputDirectory out(o.out, o.overwrite);  // refuses a non-empty DIR before any work

  // 1. Image
  StageTimer t_read(report, "read_image");
  const OrientedImage<dim> img = read_image<dim>(o.image);
  t_read.stop();
  report["input"] = image_json(img, o.image);
  check_meshable(img, o.image);
  {
    // The voxel sums behind every element mean (prefix sums in double precision, shifted by the image
    // mean) are accurate to about N·ε·max|value − mean| for N voxels. With a few huge values among
    // ordinary ones (1e20 next to 15) that is larger than the ordinary values themselves: say so.
    const ImageSummary values = summarize(img.image);
    const double spread = std::max(values.max - values.mean, values.mean - values.min);
    std::vector<float> v(img.image.data.size());
    std::transform(img.image.data.begin(), img.image.data.end(), v.begin(), [](float x) { return std::abs(x); });
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    const double typical = v[v.size() / 2];
    const double accuracy = static_cast<double>(v.size()) * 2.2e-16 * spread;
    if (typical > 0.0 && accuracy > 1e-3 * typical)
      warn(report, "input",
           fmt("%s: the values span up to %.3g from their mean while half of them are below %.3g in magnitude: "
               "element means are accurate only to about %.2g, %.2g%% of a typical value (check the image's "
               "units or clamp outliers)",
               o.image.c_str(), spread, typical, accuracy, 100.0 * accuracy / typical));
  }
  if (o.mesher != MesherKind::voxel && o.spacing <= 0.0 && o.nodes < (1L << dim))
    throw InputError("--nodes " + std::to_string(o.nodes) + ": a " + std::to_string(dim) + "D mesh needs at least " +
                     std::to_string(1 << dim) + " nodes (2 per axis)");
  const VimOptions vo = o.vim_options();
  vo.validate();

  std::optional<OrientedImage<dim>> sizing;
  if (!o.sizing.empty()) {
    if (image_dimension(o.sizing) != dim)
      throw InputError(o.sizing + ": sizing image is " + std::to_string(image_dimension(o.sizing)) +
                       "D but IMAGE is " + std::to_string(dim) + "D; they must match");
    sizing = read_image<dim>(o.sizing);
    const ImageSummary s = summarize(sizing->image);
    if (!(s.min > 0.0))
      throw InputError(o.sizing + ": sizing image has values <= 0 (min " + std::to_string(s.min) +
                       "); density must be positive everywhere");
    if (!sizing->direction.isApprox(img.direction, 1e-6))
      throw InputError(o.sizing + ": sizing image direction differs from IMAGE's; both must share one frame");
    report["sizing"] = image_json(*sizing, o.sizing);
    sizing->image = in_frame_of(img, *sizing);
  }

  MeshModel<dim> model;
  model.transform.origin = img.origin();
  model.transform.direction = img.direction;
  const auto bmin = img.image.box_min(), bmax = img.image.box_max();
  SimulationOptions sim_options;
  if (scenario) {
    check_scenario_geometry<dim>(*scenario, bmin, bmax, model.transform);
    check_modulus_image<dim>(*scenario, img.image);
    sim_options.output_file = [&out](const std::string& rel) { return out.file(rel); };
    sim_options.degree = static_cast<unsigned>(o.degree);
    if (o.degree == 2 && o.mesher == MesherKind::voxel)
      warn(report, "simulate",
           "--mesher voxel builds the voxel reference model of trilinear hexahedra (Q1) whatever the degree; "
           "--degree 2 applies to the simplex meshes (vim, grid)");
    if (o.degree == 1 && o.mesher != MesherKind::voxel && scenario->poisson_ratio >= kLockingPoisson) {
      // Linear tetrahedra lock for nearly incompressible material: the displacements come out too small
      // on the coarse meshes VIM is for (docs/validation.md, "Why VIM lost at 80 nodes").
      std::ostringstream m;
      m << scenario->source << ": material.poisson_ratio = " << std::setprecision(12) << scenario->poisson_ratio
        << " with linear (degree 1) elements: " << (dim == 3 ? "P1 tetrahedra" : "P1 triangles (plane strain)")
        << " lock for poisson_ratio >= " << kLockingPoisson
        << ", so the displacements come out too small on coarse meshes (and towards 0.5 the needle forces can be "
           "wildly wrong, even of the wrong sign); set mesh.degree: 2 in the scenario"
        << " (or --degree 2) for quadratic elements (about 5x the solve time)";
      warn(report, "simulate", m.str());
    }
  }
  // mesh.needle_refinement: a density around the needle paths that VIM keeps in E_G (§VI-E).
  std::optional<Image<dim>> needle_rho;
  if (scenario && scenario->needle_refinement && o.mesher == MesherKind::vim) {
    if (sizing)
      throw InputError("--sizing " + o.sizing + " and " + scenario->source +
                       ": mesh.needle_refinement both set the mesh density; give only one of them");
    const auto& nr = *scenario->needle_refinement;
    needle_rho = needle_refinement_density<dim>(*scenario, img.image, model.transform);
    report["needle_refinement"] = {{"size_ratio", nr.size_ratio},
                                   {"radius", nr.radius},
                                   {"peak_density", std::pow(nr.size_ratio, -static_cast<double>(dim + 2))}};
  }

  // Every input is checked; from here on progress goes to stderr.
  Log::info("image", fmt("%s: %dD, %zu voxels, values %.4g..%.4g", o.image.c_str(), dim, img.image.voxel_count(),
                         report["input"]["values"]["min"].get<double>(), report["input"]["values"]["max"].get<double>()));

  UnstructuredGrid grid;
  std::vector<IterationRecord> energy_history;
  if (o.mesher == MesherKind::voxel) {
    // The fine voxel model. PLUG-IN (engineer D/B): with --simulate, the voxel reference model
    // is built by the simulation stage from `img`; mesh-only mode writes the voxel grid itself.
    StageTimer t(report, "voxel_grid");
    grid = voxel_grid(img);
    t.stop();
    report["mesh"] = {{"mesher", "voxel"}, {"nodes", grid.points.size()}, {"elements", grid.n_cells()}};
    if (scenario) {
      StageTimer ts(report, "simulate");
      NeedleSimulation<dim> sim = NeedleSimulation<dim>::voxel(img.image, model.transform, *scenario, sim_options);
      const SimulationResult<dim> result = sim.run();
      report["simulation"] = result.report;
      for (const auto& w : result.warnings) warn(report, "simulate", w);
      write_simulation_figures<dim>(result, nullptr, out, report);
      ts.stop();
    }
  } else {
    // 2. Initial mesh: Kuhn/Freudenthal grid with the node budget (or spacing).
    StageTimer t_init(report, "initial_mesh");
    if (o.spacing <= 0.0 && o.nodes < (1L << dim))
      throw InputError("--nodes " + std::to_string(o.nodes) + ": a " + std::to_string(dim) + "D mesh needs at least " +
                       std::to_string(1 << dim) + " nodes (2 per axis)");
    const std::array<int, dim> per_axis = o.spacing > 0.0 ? nodes_per_axis_for_spacing<dim>(bmin, bmax, o.spacing)
                                                          : nodes_per_axis_for_budget<dim>(bmin, bmax, o.nodes);
    SimplexMesh<dim> initial = regular_grid_mesh<dim>(bmin, bmax, per_axis);
    t_init.stop();
    Log::info("mesh", fmt("initial grid %s: %zu nodes, %zu elements", [&] {
                std::string s;
                for (int a = 0; a < dim; ++a) s += (a ? "x" : "") + std::to_string(per_axis[a]);
                return s;
              }().c_str(), initial.n_points(), initial.n_cells()));

    if (o.mesher == MesherKind::grid) {
      StageTimer t(report, "voxel_statistics");
      model.mesh = std::move(initial);
      evaluate_fixed_mesh(img.image, model, vo, report);
      t.stop();
    } else {
      // 3. VIM optimisation (paper §IV).
      // The needle density is kept during VIM; a --sizing image only initialises (paper §VI-E, Fig. 13).
      const Image<dim>* density = needle_rho ? &*needle_rho : nullptr;
      if (sizing || density) {
        // E_G-only initialisation weighted by the density image (§VI-E), then VIM from there.
        StageTimer ts(report, "sizing");
        const auto sizing_start = std::chrono::steady_clock::now();
        auto sizing_progress = [&](const IterationRecord& r) {
          const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - sizing_start).count();
          Log::info("sizing", fmt("iteration %d: density-weighted E_G %.5g (%.4f of the start), v %.2e, moves %ld, "
                                  "swaps %ld, %.1fs",
                                  r.iteration, r.geometric, r.energy, r.v, r.moves, r.swaps, el));
        };
        initial = size_initial_mesh<dim>(sizing ? sizing->image : *density, std::move(initial), vo.max_iterations, vo,
                                         sizing_progress);
        Log::info("sizing", fmt("density-weighted initialisation from %s done",
                                sizing ? o.sizing.c_str() : "mesh.needle_refinement"));
        ts.stop();
      }
      StageTimer t(report, "optimize");
      const auto start = std::chrono::steady_clock::now();
      auto progress = [&](const IterationRecord& r) {
        const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::string left;
        if (r.iteration > 0 && r.iteration < vo.max_iterations)
          left = fmt(", at most ~%.0fs left", el / r.iteration * (vo.max_iterations - r.iteration));
        Log::info("vim", fmt("iteration %d: E %.6f (E_G %.5g, E_D %.5g), v %.2e, moves %ld, swaps %ld, %.1fs%s",
                             r.iteration, r.energy, r.geometric, r.discretization, r.v, r.moves, r.swaps, el,
                             left.c_str()));
        if (r.iteration > 0)
          Log::detail("vim", fmt("iteration %d: %ld nodes searched, %ld candidate positions evaluated, node updates "
                                 "%.3fs, swap passes %.3fs",
                                 r.iteration, r.searched, r.evaluations, r.node_seconds, r.swap_seconds));
      };
      const bool lower_bound = vo.min_dihedral_deg > 0.0 || vo.min_radius_ratio > 0.0;
      const MeshQuality initial_quality = lower_bound ? mesh_quality(initial) : MeshQuality{};
      VimResult<dim> result = optimize<dim>(img.image, std::move(initial), vo, progress, density);
      t.stop();
      if (result.ed0_estimated) {
        warn(report, "vim",
             fmt("no element of the initial mesh holds voxel centres of different values (E_D = 0 at the start; "
                 "%zu nodes for %zu voxels: the elements are about as small as the voxels or smaller, or their "
                 "faces lie on the image's edges), so E_D0 is estimated as |box| var(image) m^(-1/%d) = %.4g for "
                 "m elements and the image term keeps the fit; with elements smaller than the voxels, fewer "
                 "--nodes give the image more to shape",
                 result.mesh.n_points(), img.image.voxel_count(), dim, result.ed0));
      } else if (result.ed0 == 0.0 && vo.lambda > 0.0) {
        warn(report, "vim", "the image is constant inside the box (E_D0 = 0): the mesh is optimised for E_G only");
      }
      model.mesh = std::move(result.mesh);
      if (lower_bound) {
        // VIM never makes an element below a lower bound, but it keeps those of the initial mesh
        // until a move or swap repairs them (e.g. a grid on a very elongated box).
        long below = 0;
        for (std::size_t c = 0; c < model.mesh.n_cells(); ++c) {
          const auto x = cell_points(model.mesh, c);
          below += min_dihedral_deg<dim>(x) < vo.min_dihedral_deg ||
                   (vo.min_radius_ratio > 0.0 && normalized_radius_ratio<dim>(x) < vo.min_radius_ratio);
        }
        if (below > 0) {
          std::string bound;
          if (vo.min_dihedral_deg > 0.0) bound = fmt("--min-dihedral %g", vo.min_dihedral_deg);
          if (vo.min_radius_ratio > 0.0)
            bound += (bound.empty() ? "" : " or ") + fmt("--min-radius-ratio %g", vo.min_radius_ratio);
          warn(report, "vim",
               fmt("%ld of %zu elements are below %s: the initial mesh already had such elements (smallest "
                   "angle %.3g deg, radius ratio %.3g) and VIM only keeps or repairs them; use a smaller bound",
                   below, model.mesh.n_cells(), bound.c_str(), initial_quality.min_dihedral_deg,
                   initial_quality.min_nrr));
        }
      }
      model.values = std::move(result.values);
      energy_history = result.history;
      report["optimization"] = {{"iterations", result.history.empty() ? 0 : result.history.back().iteration},
                                {"converged", result.converged},
                                {"eg0", result.eg0},
                                {"ed0", result.ed0},
                                {"history", history_json(result.history)}};
    }

    // 4. Segmentation (§VI-B).
    if (o.threshold) {
      StageTimer t(report, "segment");
      const Segmentation seg = segment<dim>(model.mesh, model.values, *o.threshold);
      model.segment = seg.component;
      model.object.assign(seg.object.begin(), seg.object.end());
      double volume = 0.0;
      long voxels = 0;
      for (std::size_t c = 0; c < model.mesh.n_cells(); ++c)
        if (seg.object[c]) {
          volume += std::abs(signed_volume(model.mesh, c));
          voxels += model.values[c].voxels;
        }
      report["segmentation"] = {{"threshold", *o.threshold},    {"components", seg.n_components},
                                {"object_elements", seg.largest_size}, {"object_volume", volume},
                                {"object_voxels", voxels}};
      t.stop();
    }

    report["mesh"] = {{"mesher", to_string(o.mesher)},
                      {"nodes", model.mesh.n_points()},
                      {"elements", model.mesh.n_cells()},
                      {"nodes_per_axis", per_axis},
                      {"quality", quality_json(model.mesh)}};

    // 5. Needle simulation (simulation.hpp); mesh.vtu then carries the modulus used.
    if (scenario) {
      StageTimer t(report, "simulate");
      NeedleSimulation<dim> sim(model, *scenario, sim_options);  // validates against the mesh first
      model.youngs_modulus = sim.youngs_modulus();
      const SimulationResult<dim> result = sim.run();
      report["simulation"] = result.report;
      for (const auto& w : result.warnings) warn(report, "simulate", w);
      write_simulation_figures<dim>(result, &model, out, report);
      t.stop();
    }

    grid = simplex_grid(model.mesh, model.transform);
    const std::size_t nc = model.mesh.n_cells();
    Field mean{1, {}}, variance{1, {}}, voxels{1, {}}, quality{1, {}};
    for (std::size_t c = 0; c < nc; ++c) {
      mean.values.push_back(model.values[c].mean);
      variance.values.push_back(model.values[c].variance);
      voxels.values.push_back(static_cast<double>(model.values[c].voxels));
      const auto x = cell_points(model.mesh, c);
      quality.values.push_back(dim == 3 ? max_dihedral_deg<dim>(x) : min_dihedral_deg<dim>(x));
    }
    grid.cell_data["mean"] = std::move(mean);
    grid.cell_data["variance"] = std::move(variance);
    grid.cell_data["voxels"] = std::move(voxels);
    grid.cell_data["quality"] = std::move(quality);
    if (!model.segment.empty()) {
      grid.cell_data["segment"] = Field{1, std::vector<double>(model.segment.begin(), model.segment.end())};
      grid.cell_data["object"] = Field{1, std::vector<double>(model.object.begin(), model.object.end())};
    }
    if (model.youngs_modulus.size() == nc) grid.cell_data["youngs_modulus"] = Field{1, model.youngs_modulus};
    double diag = (bmax - bmin).norm();
    const auto kind = boundary_kind<dim>(model.mesh, bmin, bmax, 1e-9 * diag);
    grid.point_data["boundary"] = Field{1, std::vector<double>(kind.begin(), kind.end())};
  }

  // 6. Writers.
  StageTimer t_write(report, "write");
  write_vtu(out.file("mesh.vtu"), grid);
  if (o.mesher != MesherKind::voxel) {
    // Exports for other tools (world coordinates, material bins) and the figures.
    if (!o.exports.empty()) {
      for (const auto& f : o.exports)
        if (!(dim == 2 && f == "feb")) out.file("mesh." + f);
      // .feb and .inp carry ν: the scenario's when there is one, else ExportOptions' default (0.49).
      ExportOptions export_options;
      if (scenario) {  // complete solver jobs: the scenario's conditions, ν and element degree
        export_options.poisson_ratio = scenario->poisson_ratio;
        export_options.scenario = &*scenario;
        export_options.degree = static_cast<unsigned>(o.degree);
      }
      write_exports<dim>(model, out.path(), o.exports, report, export_options);
      for (const auto& w : report["exports"].value("warnings", json::array()))
        warn(report, "export", w.get<std::string>());
      for (auto& [fmt_name, path] : report["exports"]["files"].items()) path = "mesh." + fmt_name;
    }
    if (dim == 3)
      for (const char* name : {"sagittal", "coronal", "axial"}) out.file(std::string("figures/slice_") + name + ".png");
    else
      for (const char* name : {"mesh_overlay", "discretized"}) out.file(std::string("figures/") + name + ".png");
    write_mesh_figures<dim>(img, model, out.path(), nullptr, report);
    if (report.contains("optimization")) {
      std::vector<IterationRecord> history = energy_history;
      if (history.size() >= 2)
        report["figures"]["energy"] = write_energy_plot(history, out.file("figures/energy.png"));
    }
  } else if (!o.exports.empty()) {
    // The exports and figures are for simplex meshes: say so instead of skipping them silently.
    report["exports"]["skipped"] = "--mesher voxel writes its hexahedra to mesh.vtu only (no --export formats, no figures)";
    Log::info("write", "--mesher voxel: mesh.vtu only (the --export formats and figures are for the simplex meshes)");
  }
  t_write.stop();

  report["timing"]["total"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_total).count();
  out.file("report.json");
  report["outputs"] = out.files();
  write_text_atomically(out.path() / "report.json", [&](std::ostream& s) { s << report.dump(2) << "\n"; });
  out.commit();
  if (o.verbosity != Verbosity::quiet) print_summary(std::cout, report);
  return 0;
}

int run_info(const RunOptions& o) {
  const int d = image_dimension(o.image);
  json j = d == 2 ? image_json(read_image<2>(o.image), o.image) : image_json(read_image<3>(o.image), o.image);
  std::cout << o.image << " (" << d << "D)\n";
  print_image_info(std::cout, j);
  return 0;
}

void print_error(std::string msg) {
  for (char& c : msg)
    if (c == '\n' || c == '\r') c = ' ';
  std::cerr << "vim-pipeline: error: " << msg << "\n";
}

}  // namespace

int run(const RunOptions& o) {
  Log::set_verbosity(o.verbosity);
  try {
    if (o.info) return run_info(o);
    return image_dimension(o.image) == 2 ? run_dim<2>(o) : run_dim<3>(o);
  } catch (const InputError& e) {
    print_error(e.what());
  } catch (const std::invalid_argument& e) {
    print_error(e.what());
  } catch (const InvariantViolation& e) {
    print_error(std::string("internal error, please report it with the input: ") + e.what());
  } catch (const std::bad_alloc&) {
    print_error("out of memory (try a smaller image or fewer --nodes)");
  } catch (const std::exception& e) {
    print_error(e.what());
  }
  return 1;
}

int main_cli(int argc, char** argv) {
  int code = 0;
  const auto options = parse_command_line(argc, argv, code);
  if (!options) return code;
  return run(*options);
}

}  // namespace vim::pipeline

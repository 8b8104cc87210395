// Every call of the Python module into the mesher and the pipeline (pipeline_adapter.hpp). The work is
// the CLI's own driver, PipelineRun (vim/pipeline/run/pipeline_run.hpp), given the inputs in memory and
// called stage by stage, so that a mesh made here is the CLI's mesh.vtu bit for bit and a simulation
// writes the CLI's files. What stays here: NumPy-side inputs checked and converted, the keyword
// options turned into RunOptions, and the results read back.
#include "pipeline_adapter.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vim/invariants.hpp>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/fit/fit_run.hpp>
#include <vim/pipeline/image/image_arrays.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/vtk_output.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/version.hpp>

namespace vim::python {

namespace fs = std::filesystem;

// A mesh of the module: the run that made it (meshed, or meshed and simulated).
struct MeshState {
  std::shared_ptr<const vp::PipelineRun<2>> two;
  std::shared_ptr<const vp::PipelineRun<3>> three;
};

namespace {

// Bad input (the CLI's exit status 1 with `vim-pipeline: error: ...`) as std::invalid_argument,
// which pybind11 raises as ValueError; internal failures as std::runtime_error.
template <typename F>
auto guarded(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const vp::InputError& e) {
    throw std::invalid_argument(e.what());
  } catch (const InvariantViolation& e) {
    throw std::runtime_error(std::string("internal error, please report it with the input: ") + e.what());
  }
}

// --- images ---------------------------------------------------------------------------------------

// An image given as an array: the checks read_image makes on a file's header (the voxel and direction
// checks are oriented_image's; a NaN voxel is named here first, by its index in the flat array).
void check_array_image(const ImageData& im) {
  const std::string& f = im.source;
  const auto d = static_cast<std::size_t>(im.dim);
  if (im.dim != 2 && im.dim != 3) throw vp::InputError(f + ": the image must be 2D or 3D");
  if (im.size.size() != d || im.spacing.size() != d || im.origin.size() != d || im.direction.size() != d * d)
    throw vp::InputError(f + ": spacing and origin need " + std::to_string(d) + " values and direction " +
                         std::to_string(d * d));
  std::size_t n = 1;
  for (long s : im.size) n *= static_cast<std::size_t>(std::max(s, 0L));
  if (n == 0 || n != im.values.size()) throw vp::InputError(f + ": the image is empty");
  for (std::size_t a = 0; a < d; ++a) {
    if (!(im.spacing[a] > 0.0) || !std::isfinite(im.spacing[a]))
      throw vp::InputError(f + ": spacing[" + std::to_string(a) + "] = " + std::to_string(im.spacing[a]) +
                           " must be a finite number > 0");
    if (!std::isfinite(im.origin[a])) throw vp::InputError(f + ": origin is not finite");
  }
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(im.values[k]))
      throw vp::InputError(f + ": voxel " + std::to_string(k) +
                           " is NaN or infinite; every voxel must be finite");
}

// The image of an ImageData; an array is checked first as read_image checks a file's header.
template <int dim>
vp::OrientedImage<dim> to_oriented(const ImageData& im) {
  if (im.source == "array") check_array_image(im);
  return vp::oriented_image<dim>(im.size, im.spacing, im.origin, im.direction, im.values, im.source);
}

template <int dim>
ImageData from_oriented(const vp::OrientedImage<dim>& o, const std::string& source) {
  ImageData im;
  im.dim = dim;
  im.source = source;
  im.size.assign(o.image.size.begin(), o.image.size.end());
  im.spacing.assign(o.image.spacing.begin(), o.image.spacing.end());
  im.origin.assign(o.image.origin.begin(), o.image.origin.end());
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) im.direction.push_back(o.direction(a, b));
  im.values = o.image.data;
  return im;
}

// --- options ----------------------------------------------------------------------------------------

// The ranges the CLI's option parser enforces, named by the Python keywords.
void check_settings(const MeshSettings& s) {
  auto range = [](const char* name, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      throw vp::InputError(std::string(name) + " = " + std::to_string(v) + ": must be in [" +
                           std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  const vp::MeshOptions& o = s.options;
  if (s.has("nodes")) range("nodes", static_cast<double>(o.nodes), 4, 1e8);
  range("max_iterations", o.max_iterations, 0, 100000);
  range("threads", o.threads, 0, 1024);
  if (s.has("search_width")) range("search_width", o.search_width, 0, 1000);
  if (s.has("degree")) range("degree", o.degree, 1, 2);
  if (s.threshold && !std::isfinite(*s.threshold)) throw vp::InputError("threshold: must be a finite number");
  if (s.has("spacing") && !(o.spacing > 0.0 && std::isfinite(o.spacing)))
    throw vp::InputError("spacing = " + std::to_string(o.spacing) + ": must be a finite number > 0");
  if (s.mesher != "vim" && s.mesher != "grid")
    throw vp::InputError("mesher = " + s.mesher + ": must be vim or grid");
}

// The keyword options as the CLI's options. command_line lists the flags the caller set among those a
// scenario's mesh keys would otherwise set (nodes, spacing, lambda, degree, min_dihedral), as the
// CLI's command line does; report.json records it.
vp::RunOptions run_options(const MeshSettings& s, const std::string& image, const fs::path& out) {
  vp::RunOptions o;
  o.image = image;
  o.out = out;
  o.command_line = {"vimpipeline", image};
  auto given = [&](const char* flag, auto value) {
    std::ostringstream text;
    text << std::setprecision(17) << value;
    o.command_line.insert(o.command_line.end(), {flag, text.str()});
  };
  static_cast<vp::MeshOptions&>(o) = s.options;
  if (s.has("nodes")) given("--nodes", o.nodes);
  if (s.has("spacing")) given("--spacing", o.spacing);
  if (s.has("lam")) given("--lambda", o.lambda);
  if (s.has("degree")) given("--degree", o.degree);
  if (s.has("min_dihedral")) given("--min-dihedral", o.min_dihedral_deg);
  if (s.sizing) o.sizing = s.sizing->source;
  if (s.labels_alone) o.labels = image;
  if (s.labels) o.labels = s.labels->source == image ? s.labels->source + " (labels)" : s.labels->source;
  o.label_moduli = s.label_moduli;
  o.threshold = s.threshold;
  o.mesher = *vp::mesher_kind(s.mesher);  // vim or grid (check_settings)
  o.verbosity = vp::Verbosity::quiet;
  return o;
}

IterationData iteration_data(const std::string& stage, const IterationRecord& r) {
  return {stage, r.iteration, r.energy, r.geometric, r.discretization, r.v, r.seconds, r.moves, r.swaps};
}

// The run's inputs from memory: the image (and sizing image) checked as read_image checks a file.
template <int dim>
vp::RunInputs<dim> run_inputs(vp::OrientedImage<dim> image, const MeshSettings& s,
                              std::optional<vp::Scenario> scenario, const ProgressFunction& progress) {
  vp::RunInputs<dim> in;
  in.image = std::move(image);
  if (s.sizing) {
    if (s.sizing->dim != dim)
      throw vp::InputError(s.sizing->source + ": sizing image is " + std::to_string(s.sizing->dim) +
                           "D but the image is " + std::to_string(dim) + "D; they must match");
    in.sizing = to_oriented<dim>(*s.sizing);
  }
  if (s.labels) {
    if (s.labels->dim != dim)
      throw vp::InputError(s.labels->source + ": the label image is " + std::to_string(s.labels->dim) +
                           "D but the image is " + std::to_string(dim) + "D; they must match");
    in.labels = to_oriented<dim>(*s.labels);
  }
  in.scenario = std::move(scenario);
  in.tool = "vimpipeline";
  in.keep_step_fields = true;
  in.on_iteration = [progress](const std::string& stage, const IterationRecord& r) {
    progress(iteration_data(stage, r));
  };
  return in;
}

// A run on `image` up to its mesh (read_inputs, make_mesh); files go to `out` if given.
template <int dim>
std::shared_ptr<vp::PipelineRun<dim>> meshed_run(const ImageData& image, const MeshSettings& s,
                                                 std::optional<vp::Scenario> scenario, const fs::path& out,
                                                 const ProgressFunction& progress) {
  check_settings(s);
  auto run = std::make_shared<vp::PipelineRun<dim>>(
      run_options(s, image.source, out),
      run_inputs<dim>(to_oriented<dim>(image), s, std::move(scenario), progress));
  run->read_inputs();
  run->make_mesh();
  return run;
}

template <int dim>
MeshData mesh_data(std::shared_ptr<const vp::PipelineRun<dim>> run) {
  MeshData d;
  d.dim = dim;
  const vp::UnstructuredGrid grid = run->mesh_vtu_grid();
  for (const auto& p : grid.points)
    for (int a = 0; a < dim; ++a) d.points.push_back(p[a]);
  d.cells = grid.connectivity;
  for (const auto& [name, field] : grid.cell_data) d.cell_data[name] = field.values;
  for (const auto& [name, field] : grid.point_data) d.point_data[name] = field.values;
  const std::string stage = vp::to_string(run->options().mesher);
  for (const auto& r : run->energy_history()) d.history.push_back(iteration_data(stage, r));
  d.warnings = run->warnings();
  auto state = std::make_shared<MeshState>();
  if constexpr (dim == 2)
    state->two = std::move(run);
  else
    state->three = std::move(run);
  d.state = std::move(state);
  return d;
}

// --- simulation -------------------------------------------------------------------------------------

template <int dim>
NeedleData needle_data(const vp::NeedleRun<dim>& run) {
  NeedleData n;
  n.name = run.name;
  n.depth = run.depth;
  n.axial_force = run.axial_force;
  n.lateral_force = run.lateral_force;
  n.friction_force = run.friction_force;
  n.tip_force = run.tip_force;
  n.tip_cutting = run.tip_cutting;
  for (const auto& p : run.punctures)
    n.punctures.insert(n.punctures.end(), {p.depth, p.force_before, p.force_after});
  n.max_strain = run.max_strain;
  auto append = [](std::vector<double>& out, const Eigen::Matrix<double, dim, 1>& v) {
    for (int a = 0; a < dim; ++a) out.push_back(v[a]);
  };
  for (std::size_t s = 0; s < run.depth.size(); ++s) {
    append(n.tip, run.tip[s]);
    append(n.force, run.force[s]);
    for (const auto& t : run.target_displacement[s]) append(n.target_displacement, t);
  }
  for (const auto& step : run.vertex_displacement)
    for (const auto& u : step) append(n.displacement, u);
  for (const auto& d : run.tip_deviation) append(n.tip_deviation, d);
  n.tip_angle = run.tip_angle;
  for (const auto& line : run.shape) {
    n.shape.emplace_back();
    for (const auto& x : line) append(n.shape.back(), x);
  }
  return n;
}

template <int dim>
void append_seeds(const vp::NeedleRun<dim>& run, SeedData& out) {
  const auto append = [](std::vector<double>& v, const Eigen::Matrix<double, dim, 1>& x) {
    v.insert(v.end(), x.data(), x.data() + dim);
  };
  for (const auto& seed : run.seeds) {
    out.needle.push_back(run.name);
    out.depth.push_back(seed.depth);
    append(out.planned, seed.planned);
    append(out.final_position, seed.final_position());
    append(out.error, seed.error());
    out.release_step.push_back(seed.release_step);
  }
}

// The stages after the mesh: the model, the needle insertion, the CLI's files and report.json.
template <int dim>
SimulationData simulate_run(std::shared_ptr<vp::PipelineRun<dim>> run, const ProgressFunction& progress) {
  progress({"simulate", 0, 0, 0, 0, 0, 0, 0, 0});
  run->build_model();  // validates the scenario against the mesh first
  run->simulate();
  run->write_outputs();
  const vp::ReportResult& written = run->write_report();
  SimulationData out;
  const vp::SimulationResult<dim>& result = *run->simulation_result();
  for (const auto& needle : result.needles) {
    out.needles.push_back(needle_data(needle));
    append_seeds(needle, out.seeds);
  }
  out.target_names = result.target_names;
  out.files = written.outputs;
  out.report_json = run->report().dump(2);
  out.mesh = mesh_data<dim>(std::move(run));
  out.warnings = out.mesh.warnings;
  return out;
}

template <int dim>
SimulationData simulate_image(const ImageData& image, const MeshSettings& s, vp::Scenario scenario,
                              const fs::path& dir, const ProgressFunction& progress) {
  return simulate_run<dim>(meshed_run<dim>(image, s, std::move(scenario), dir, progress), progress);
}

// A simulation on the mesh of an earlier run: its options, with the degree of `s` if given.
template <int dim>
SimulationData simulate_mesh(const vp::PipelineRun<dim>& meshed, const MeshSettings& s, vp::Scenario scenario,
                             const fs::path& dir, const ProgressFunction& progress) {
  check_settings(s);
  vp::RunOptions o = meshed.options();
  o.out = dir;
  if (s.has("degree")) {
    o.degree = s.options.degree;
    o.command_line.insert(o.command_line.end(), {"--degree", std::to_string(o.degree)});
  }
  vp::RunInputs<dim> in = run_inputs<dim>(meshed.image(), MeshSettings{}, std::move(scenario), progress);
  o.sizing.clear();  // the mesh is made
  auto run = std::make_shared<vp::PipelineRun<dim>>(o, std::move(in));
  run->read_inputs();
  run->reuse_mesh(meshed);
  return simulate_run<dim>(std::move(run), progress);
}

}  // namespace

// --- the interface ------------------------------------------------------------------------------------

ImageData read_image(const std::string& path) {
  return guarded([&] {
    return vp::image_dimension(path) == 2 ? from_oriented(vp::read_image<2>(path), path)
                                          : from_oriented(vp::read_image<3>(path), path);
  });
}

MeshData mesh(const ImageData& image, const MeshSettings& settings, const ProgressFunction& progress) {
  vp::Log::set_verbosity(vp::Verbosity::quiet);
  return guarded([&] {
    if (image.dim == 2) return mesh_data<2>(meshed_run<2>(image, settings, std::nullopt, {}, progress));
    if (image.dim == 3) return mesh_data<3>(meshed_run<3>(image, settings, std::nullopt, {}, progress));
    throw vp::InputError(image.source + ": the image must be 2D or 3D");
  });
}

void write_vtu(const MeshData& mesh, const std::string& path) {
  guarded([&] {
    if (mesh.state->two)
      vp::write_vtu(path, mesh.state->two->mesh_vtu_grid());
    else
      vp::write_vtu(path, mesh.state->three->mesh_vtu_grid());
  });
}

SimulationData simulate(const ImageData* image, const MeshData* premeshed, const MeshSettings& settings,
                        const ScenarioSource& source, const std::string& staging_dir,
                        const ProgressFunction& progress) {
  vp::Log::set_verbosity(vp::Verbosity::quiet);
  return guarded([&] {
    const int dim = image ? image->dim : premeshed->dim;
    const vp::Scenario scenario = source.path.empty() ? vp::parse_scenario_text(source.text, dim, source.name)
                                                      : vp::read_scenario(source.path, dim);
    if (premeshed)
      return dim == 2 ? simulate_mesh<2>(*premeshed->state->two, settings, scenario, staging_dir, progress)
                      : simulate_mesh<3>(*premeshed->state->three, settings, scenario, staging_dir, progress);
    return dim == 2 ? simulate_image<2>(*image, settings, scenario, staging_dir, progress)
                    : simulate_image<3>(*image, settings, scenario, staging_dir, progress);
  });
}

std::string fit_forces(const std::string& image, const MeshSettings& settings, const std::string& scenario,
                       const std::string& measured, const std::string& out, bool overwrite) {
  vp::Log::set_verbosity(vp::Verbosity::quiet);
  return guarded([&] {
    check_settings(settings);
    vp::RunOptions o = run_options(settings, image, out);
    o.simulate = scenario;
    o.fit_forces = measured;
    o.overwrite = overwrite;
    o.command_line.insert(o.command_line.end(), {"--simulate", scenario, "--fit-forces", measured});
    vp::run_force_fit(o);
    std::ifstream in(fs::path(out) / "fit.json");
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  });
}

std::string version() { return VIM_VERSION_STRING; }

}  // namespace vim::python

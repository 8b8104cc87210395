// Every call of the Python module into the mesher and the pipeline (pipeline_adapter.hpp). The stages
// run in the CLI's order with the CLI's options and checks, so that a mesh made here equals the
// CLI's mesh.vtu bit for bit: read image → initial grid → [sizing] → VIM (or the grid) → segmentation
// → [simulation] → the CLI's output files.
#include "pipeline_adapter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vim/energy.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/invariants.hpp>
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/exports.hpp>
#include <vim/pipeline/figures.hpp>
#include <vim/pipeline/image_io.hpp>
#include <vim/pipeline/progress.hpp>
#include <vim/pipeline/report.hpp>
#include <vim/pipeline/scenario.hpp>
#include <vim/pipeline/simulation.hpp>
#include <vim/pipeline/vtk_output.hpp>
#include <vim/quality.hpp>
#include <vim/segmentation.hpp>
#include <vim/sizing.hpp>
#include <vim/version.hpp>
#include <vim/voxel_statistics.hpp>

namespace vim::python {

namespace fs = std::filesystem;
namespace vp = vim::pipeline;
using nlohmann::json;

template <int dim>
struct Staged {
  vp::OrientedImage<dim> image;
  vp::MeshModel<dim> model;
  std::vector<IterationRecord> history;
  json report;                // input, options, mesh, optimization, segmentation, warnings, timing
  vp::UnstructuredGrid grid;  // mesh.vtu
};

struct MeshState {
  std::shared_ptr<const Staged<2>> two;
  std::shared_ptr<const Staged<3>> three;
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

void warn(json& report, const std::string& message) { report["warnings"].push_back(message); }

// --- images ---------------------------------------------------------------------------------------

// An image given as an array: the checks read_image makes on a file's header and voxels.
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
  for (std::size_t i = 0; i < d; ++i)
    for (std::size_t j = 0; j < d; ++j) {
      double dot = 0.0;
      for (std::size_t k = 0; k < d; ++k) dot += im.direction[k * d + i] * im.direction[k * d + j];
      if (!(std::abs(dot - (i == j ? 1.0 : 0.0)) < 1e-6))
        throw vp::InputError(f +
                             ": direction is not orthonormal (its columns must be unit, perpendicular axes)");
    }
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(im.values[k]))
      throw vp::InputError(f + ": voxel " + std::to_string(k) +
                           " is NaN or infinite; every voxel must be finite");
}

template <int dim>
vp::OrientedImage<dim> to_oriented(const ImageData& im) {
  if (im.source == "array") check_array_image(im);
  vp::OrientedImage<dim> o;
  for (int a = 0; a < dim; ++a) {
    o.image.size[a] = im.size[a];
    o.image.spacing[a] = im.spacing[a];
    o.image.origin[a] = im.origin[a];
    for (int b = 0; b < dim; ++b) o.direction(a, b) = im.direction[a * dim + b];
  }
  o.image.data = im.values;
  return o;
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

// The CLI's check that every axis has the 2 voxels a mesh needs.
template <int dim>
void check_meshable(const vp::OrientedImage<dim>& img, const std::string& file) {
  for (int a = 0; a < dim; ++a)
    if (img.image.size[a] < 2) {
      std::string sz;
      for (int b = 0; b < dim; ++b) sz += (b ? " x " : "") + std::to_string(img.image.size[b]);
      throw vp::InputError(
          file + ": image is 1 voxel thick along axis " + std::to_string(a) + " (size " + sz +
          "); meshing needs at least 2 voxels per axis (store a single slice as a 2D image)");
    }
}

// --- meshing stages ---------------------------------------------------------------------------------

// The ranges the CLI's option parser enforces, named by the Python keywords.
void check_settings(const MeshSettings& s) {
  auto range = [](const char* name, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      throw vp::InputError(std::string(name) + " = " + std::to_string(v) + ": must be in [" +
                           std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  if (s.nodes) range("nodes", static_cast<double>(*s.nodes), 4, 1e8);
  range("max_iterations", s.max_iterations, 0, 100000);
  range("threads", s.threads, 0, 1024);
  if (s.search_width) range("search_width", *s.search_width, 0, 1000);
  if (s.degree) range("degree", *s.degree, 1, 2);
  if (s.threshold && !std::isfinite(*s.threshold)) throw vp::InputError("threshold: must be a finite number");
}

VimOptions vim_options(const MeshSettings& s) {
  VimOptions v;
  v.lambda = s.lambda.value_or(v.lambda);
  v.max_dihedral_deg = s.max_dihedral;
  v.min_dihedral_deg = s.min_dihedral.value_or(0.0);
  v.min_radius_ratio = s.min_radius_ratio;
  v.max_iterations = s.max_iterations;
  v.convergence = s.convergence.value_or(v.convergence);
  v.energy_convergence = s.energy_convergence.value_or(v.energy_convergence);
  v.search_width = s.search_width.value_or(v.search_width);
  v.seed = s.seed;
  v.threads = s.threads;
  return v;
}

json options_json(const MeshSettings& s) {
  const VimOptions v = vim_options(s);
  return {{"nodes", s.spacing ? json(nullptr) : json(s.nodes.value_or(1000))},
          {"spacing", s.spacing.value_or(0.0)},
          {"lambda", v.lambda},
          {"max_dihedral_deg", v.max_dihedral_deg},
          {"min_dihedral_deg", v.min_dihedral_deg},
          {"min_radius_ratio", v.min_radius_ratio},
          {"max_iterations", v.max_iterations},
          {"convergence", v.convergence},
          {"energy_convergence", v.energy_convergence},
          {"search_width", v.search_width},
          {"seed", v.seed},
          {"threads", v.threads},
          {"threshold", s.threshold ? json(*s.threshold) : json(nullptr)},
          {"mesher", s.mesher},
          {"degree", s.degree.value_or(1)}};
}

IterationData iteration_data(const std::string& stage, const IterationRecord& r) {
  return {stage, r.iteration, r.energy, r.geometric, r.discretization, r.v, r.seconds, r.moves, r.swaps};
}

template <int dim>
SimplexMesh<dim> initial_grid(const Staged<dim>& st, const MeshSettings& s, json& report) {
  const auto bmin = st.image.image.box_min(), bmax = st.image.image.box_max();
  const long nodes = s.nodes.value_or(1000);
  if (!s.spacing && nodes < (1L << dim))
    throw vp::InputError("nodes = " + std::to_string(nodes) + ": a " + std::to_string(dim) +
                         "D mesh needs at least " + std::to_string(1 << dim) + " nodes (2 per axis)");
  if (s.spacing && !(*s.spacing > 0.0 && std::isfinite(*s.spacing)))
    throw vp::InputError("spacing = " + std::to_string(*s.spacing) + ": must be a finite number > 0");
  const std::array<int, dim> per_axis = s.spacing ? nodes_per_axis_for_spacing<dim>(bmin, bmax, *s.spacing)
                                                  : nodes_per_axis_for_budget<dim>(bmin, bmax, nodes);
  report["mesh"]["nodes_per_axis"] = per_axis;
  return regular_grid_mesh<dim>(bmin, bmax, per_axis);
}

// The grid mesher: per-element values of the fixed grid and its energies as history[0].
template <int dim>
void evaluate_fixed_mesh(Staged<dim>& st, const VimOptions& vo) {
  const VoxelStatistics<dim> stats(st.image.image);
  auto& m = st.model;
  m.values.resize(m.mesh.n_cells());
  IterationRecord r;
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    const auto x = cell_points(m.mesh, c);
    m.values[c] = stats.value(x);
    r.geometric += geometric_energy<dim>(x);
    r.discretization += discretization_energy(std::abs(signed_volume<dim>(x)), m.values[c].variance);
  }
  r.energy =
      EnergyNormalization{r.geometric, r.discretization, vo.lambda}.combined(r.geometric, r.discretization);
  st.history = {r};
  st.report["optimization"] = {{"iterations", 0},
                               {"converged", false},
                               {"eg0", r.geometric},
                               {"ed0", r.discretization},
                               {"history", vp::history_json(st.history)}};
}

// VIM (paper §IV), after the density-weighted E_G-only initialisation when there is a density (§VI-E).
template <int dim>
void optimize_stage(Staged<dim>& st, SimplexMesh<dim> initial, const VimOptions& vo, const Image<dim>* sizing,
                    const Image<dim>* density, const ProgressFunction& progress) {
  if (sizing || density) {
    vp::StageTimer t(st.report, "sizing");
    initial =
        size_initial_mesh<dim>(sizing ? *sizing : *density, std::move(initial), vo.max_iterations, vo,
                               [&](const IterationRecord& r) { progress(iteration_data("sizing", r)); });
    t.stop();
  }
  vp::StageTimer t(st.report, "optimize");
  VimResult<dim> result = optimize<dim>(
      st.image.image, std::move(initial), vo,
      [&](const IterationRecord& r) { progress(iteration_data("vim", r)); }, density);
  t.stop();
  if (result.ed0_estimated)
    warn(st.report,
         "no element of the initial mesh holds voxel centres of different values (E_D = 0 at the "
         "start), so E_D0 is estimated as |box| var(image) m^(-1/d) and the image term keeps the fit");
  else if (result.ed0 == 0.0 && vo.lambda > 0.0)
    warn(st.report, "the image is constant inside the box (E_D0 = 0): the mesh is optimised for E_G only");
  st.model.mesh = std::move(result.mesh);
  st.model.values = std::move(result.values);
  st.history = result.history;
  st.report["optimization"] = {{"iterations", result.history.empty() ? 0 : result.history.back().iteration},
                               {"converged", result.converged},
                               {"eg0", result.eg0},
                               {"ed0", result.ed0},
                               {"history", vp::history_json(result.history)}};
}

// Segmentation (§VI-B): face-connected components of the elements with mean > threshold.
template <int dim>
void segment_stage(Staged<dim>& st, double threshold) {
  auto& m = st.model;
  const Segmentation seg = segment<dim>(m.mesh, m.values, threshold);
  m.segment = seg.component;
  m.object.assign(seg.object.begin(), seg.object.end());
  double volume = 0.0;
  long voxels = 0;
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c)
    if (seg.object[c]) {
      volume += std::abs(signed_volume(m.mesh, c));
      voxels += m.values[c].voxels;
    }
  st.report["segmentation"] = {{"threshold", threshold},
                               {"components", seg.n_components},
                               {"object_elements", seg.largest_size},
                               {"object_volume", volume},
                               {"object_voxels", voxels}};
}

// mesh.vtu's grid: world points, cells, the per-element fields and the boundary point field.
template <int dim>
void build_grid(Staged<dim>& st) {
  const auto& m = st.model;
  st.grid = vp::simplex_grid(m.mesh, m.transform);
  vp::Field mean{1, {}}, variance{1, {}}, voxels{1, {}}, quality{1, {}};
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    mean.values.push_back(m.values[c].mean);
    variance.values.push_back(m.values[c].variance);
    voxels.values.push_back(static_cast<double>(m.values[c].voxels));
    const auto x = cell_points(m.mesh, c);
    quality.values.push_back(dim == 3 ? max_dihedral_deg<dim>(x) : min_dihedral_deg<dim>(x));
  }
  auto& cd = st.grid.cell_data;
  cd["mean"] = std::move(mean);
  cd["variance"] = std::move(variance);
  cd["voxels"] = std::move(voxels);
  cd["quality"] = std::move(quality);
  if (!m.segment.empty()) {
    cd["segment"] = vp::Field{1, std::vector<double>(m.segment.begin(), m.segment.end())};
    cd["object"] = vp::Field{1, std::vector<double>(m.object.begin(), m.object.end())};
  }
  if (m.youngs_modulus.size() == m.mesh.n_cells()) cd["youngs_modulus"] = vp::Field{1, m.youngs_modulus};
  const auto bmin = st.image.image.box_min(), bmax = st.image.image.box_max();
  const auto kind = boundary_kind<dim>(m.mesh, bmin, bmax, 1e-9 * (bmax - bmin).norm());
  st.grid.point_data["boundary"] = vp::Field{1, std::vector<double>(kind.begin(), kind.end())};
}

// The sizing image in the image's frame, checked as the CLI checks --sizing.
template <int dim>
std::optional<Image<dim>> sizing_image(const Staged<dim>& st, const MeshSettings& s) {
  if (!s.sizing) return std::nullopt;
  const std::string& f = s.sizing->source;
  if (s.sizing->dim != dim)
    throw vp::InputError(f + ": sizing image is " + std::to_string(s.sizing->dim) + "D but the image is " +
                         std::to_string(dim) + "D; they must match");
  const vp::OrientedImage<dim> sizing = to_oriented<dim>(*s.sizing);
  if (!(vp::summarize(sizing.image).min > 0.0))
    throw vp::InputError(f + ": sizing image has values <= 0; density must be positive everywhere");
  if (!sizing.direction.isApprox(st.image.direction, 1e-6))
    throw vp::InputError(f + ": sizing image direction differs from the image's; both must share one frame");
  return vp::in_frame_of(st.image, sizing);
}

// Every meshing stage; `density` is the scenario's needle refinement (kept during VIM).
template <int dim>
std::shared_ptr<Staged<dim>> mesh_dim(vp::OrientedImage<dim> img, const std::string& source,
                                      const MeshSettings& s, const Image<dim>* density,
                                      const ProgressFunction& progress) {
  auto st = std::make_shared<Staged<dim>>();
  st->image = std::move(img);
  check_meshable(st->image, source);
  if (s.mesher != "vim" && s.mesher != "grid")
    throw vp::InputError("mesher = " + s.mesher + ": must be vim or grid");
  check_settings(s);
  const VimOptions vo = vim_options(s);
  vo.validate();
  st->report["tool"] = {{"name", "vimpipeline"}, {"version", VIM_VERSION_STRING}};
  st->report["options"] = options_json(s);
  st->report["input"] = vp::image_json(st->image, source);
  st->model.transform.origin = st->image.origin();
  st->model.transform.direction = st->image.direction;
  const std::optional<Image<dim>> sizing = sizing_image(*st, s);
  if (sizing && density)
    throw vp::InputError(
        "sizing and the scenario's mesh.needle_refinement both set the mesh density; give only one");
  SimplexMesh<dim> initial = initial_grid(*st, s, st->report);
  if (s.mesher == "grid") {
    st->model.mesh = std::move(initial);
    evaluate_fixed_mesh(*st, vo);
  } else {
    optimize_stage(*st, std::move(initial), vo, sizing ? &*sizing : nullptr, density, progress);
  }
  if (s.threshold) segment_stage(*st, *s.threshold);
  st->report["mesh"].update({{"mesher", s.mesher},
                             {"nodes", st->model.mesh.n_points()},
                             {"elements", st->model.mesh.n_cells()},
                             {"quality", vp::quality_json(st->model.mesh)}});
  build_grid(*st);
  return st;
}

template <int dim>
MeshData mesh_data(std::shared_ptr<const Staged<dim>> st) {
  MeshData d;
  d.dim = dim;
  for (const auto& p : st->grid.points)
    for (int a = 0; a < dim; ++a) d.points.push_back(p[a]);
  d.cells = st->grid.connectivity;
  for (const auto& [name, field] : st->grid.cell_data) d.cell_data[name] = field.values;
  for (const auto& [name, field] : st->grid.point_data) d.point_data[name] = field.values;
  const std::string stage = st->report["options"]["mesher"].template get<std::string>();
  for (const auto& r : st->history) d.history.push_back(iteration_data(stage, r));
  if (st->report.contains("warnings"))
    for (const auto& w : st->report["warnings"]) d.warnings.push_back(w.template get<std::string>());
  auto state = std::make_shared<MeshState>();
  if constexpr (dim == 2)
    state->two = st;
  else
    state->three = st;
  d.state = std::move(state);
  return d;
}

// --- simulation -------------------------------------------------------------------------------------

// The scenario's mesh keys (nodes, lambda, degree, min_dihedral) apply unless the caller set them.
MeshSettings with_scenario_mesh(MeshSettings s, const vp::Scenario& sc) {
  if (sc.nodes && !s.nodes && !s.spacing) s.nodes = *sc.nodes;
  if (sc.lambda && !s.lambda) s.lambda = *sc.lambda;
  if (sc.degree && !s.degree) s.degree = static_cast<int>(*sc.degree);
  if (sc.min_dihedral && !s.min_dihedral) s.min_dihedral = *sc.min_dihedral;
  return s;
}

// The needle's force and target-displacement plots and the deformed mesh at the last step, as the CLI draws
// them.
template <int dim>
void write_simulation_figures(const vp::SimulationResult<dim>& result, const vp::MeshModel<dim>& model,
                              const std::function<fs::path(const std::string&)>& file, json& report) {
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
    const std::string force_png = "figures/" + prefix + "needle_force.png";
    fig["force"] = vp::write_line_plot(file(force_png), run.depth, {run.axial_force, run.lateral_force},
                                       {"axial force", "lateral force"}, "needle depth [" + length + "]",
                                       "force on the needle [" + force + "]");
    fig["force"]["file"] = force_png;
    if (!run.target_displacement.empty() && !run.target_displacement.front().empty()) {
      std::vector<std::vector<double>> series(run.target_displacement.front().size());
      for (const auto& step : run.target_displacement)
        for (std::size_t t = 0; t < step.size() && t < series.size(); ++t)
          series[t].push_back(step[t].norm());
      std::vector<std::string> names;
      for (std::size_t t = 0; t < series.size(); ++t)
        names.push_back(t < result.target_names.size() ? result.target_names[t]
                                                       : "target " + std::to_string(t + 1));
      const std::string png = "figures/" + prefix + "target_displacement.png";
      fig["targets"] =
          vp::write_line_plot(file(png), run.depth, series, names, "needle depth [" + length + "]",
                              "target displacement |u| [" + length + "]");
      fig["targets"]["file"] = png;
    }
    if (!run.vertex_displacement.empty() && run.vertex_displacement.back().size() == model.mesh.n_points()) {
      std::vector<Eigen::Matrix<double, dim, 1>> u;
      for (const auto& w : run.vertex_displacement.back()) u.push_back(model.transform.vector_to_frame(w));
      int normal = dim - 1;
      if constexpr (dim == 3) normal = vp::slice_normal_along(model.transform.vector_to_frame(run.axis));
      const std::string png = "figures/" + prefix + "deformed.png";
      fig["deformed"] = vp::write_deformed_slice<dim>(
          model, u, file(png), model.transform.to_frame(run.tip.back()), normal, "|u| [" + length + "]");
      fig["deformed"]["file"] = png;
    }
  }
}

// mesh.vtu, the exports, the mesh and energy figures and report.json, as the CLI writes them.
template <int dim>
void write_model_files(Staged<dim>& st, const vp::Scenario& scenario,
                       const std::function<fs::path(const std::string&)>& file, const fs::path& dir) {
  vp::write_vtu(file("mesh.vtu"), st.grid);
  const std::vector<std::string>& formats = vp::export_formats();
  for (const auto& f : formats)
    if (!(dim == 2 && f == "feb")) file("mesh." + f);
  vp::ExportOptions export_options;
  export_options.poisson_ratio = scenario.poisson_ratio;
  vp::write_exports<dim>(st.model, dir, formats, st.report, export_options);
  for (auto& [name, path] : st.report["exports"]["files"].items()) path = "mesh." + name;
  if (dim == 3)
    for (const char* name : {"sagittal", "coronal", "axial"})
      file(std::string("figures/slice_") + name + ".png");
  else
    for (const char* name : {"mesh_overlay", "discretized"}) file(std::string("figures/") + name + ".png");
  vp::write_mesh_figures<dim>(st.image, st.model, dir, nullptr, st.report);
  if (st.history.size() >= 2)
    st.report["figures"]["energy"] = vp::write_energy_plot(st.history, file("figures/energy.png"));
}

template <int dim>
NeedleData needle_data(const vp::NeedleRun<dim>& run) {
  NeedleData n;
  n.name = run.name;
  n.depth = run.depth;
  n.axial_force = run.axial_force;
  n.lateral_force = run.lateral_force;
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
  return n;
}

template <int dim>
SimulationData simulate_dim(std::shared_ptr<Staged<dim>> st, const vp::Scenario& scenario,
                            const MeshSettings& s, const fs::path& dir, const ProgressFunction& progress) {
  std::vector<std::string> files;
  auto file = [&](const std::string& rel) {
    const fs::path p = dir / rel;
    fs::create_directories(p.parent_path());
    if (std::find(files.begin(), files.end(), rel) == files.end()) files.push_back(rel);
    return p;
  };
  vp::SimulationOptions options;
  options.output_file = file;
  options.degree = static_cast<unsigned>(s.degree.value_or(1));
  options.keep_step_fields = true;
  options.progress = false;
  progress({"simulate", 0, 0, 0, 0, 0, 0, 0, 0});
  vp::StageTimer t(st->report, "simulate");
  vp::NeedleSimulation<dim> sim(st->model, scenario, options);  // validates against the mesh first
  st->model.youngs_modulus = sim.youngs_modulus();
  const vp::SimulationResult<dim> result = sim.run();
  t.stop();
  st->report["simulation"] = result.report;
  for (const auto& w : result.warnings) warn(st->report, w);
  write_simulation_figures<dim>(result, st->model, file, st->report);
  build_grid(*st);  // now with youngs_modulus
  write_model_files(*st, scenario, file, dir);
  file("report.json");
  st->report["outputs"] = files;
  vp::write_text_atomically(dir / "report.json", [&](std::ostream& o) { o << st->report.dump(2) << "\n"; });

  SimulationData out;
  out.mesh = mesh_data<dim>(st);
  for (const auto& run : result.needles) out.needles.push_back(needle_data(run));
  out.target_names = result.target_names;
  out.warnings = out.mesh.warnings;
  out.files = files;
  out.report_json = st->report.dump(2);
  return out;
}

template <int dim>
SimulationData simulate_image(const ImageData& image, const MeshSettings& given, const vp::Scenario& scenario,
                              const fs::path& dir, const ProgressFunction& progress) {
  const MeshSettings s = with_scenario_mesh(given, scenario);
  vp::OrientedImage<dim> img = to_oriented<dim>(image);
  vp::WorldTransform<dim> transform;
  transform.origin = img.origin();
  transform.direction = img.direction;
  vp::check_scenario_geometry<dim>(scenario, img.image.box_min(), img.image.box_max(), transform);
  vp::check_modulus_image<dim>(scenario, img.image);
  std::optional<Image<dim>> density;
  if (scenario.needle_refinement && s.mesher == "vim")
    density = vp::needle_refinement_density<dim>(scenario, img.image, transform);
  auto st = mesh_dim<dim>(std::move(img), image.source, s, density ? &*density : nullptr, progress);
  return simulate_dim<dim>(st, scenario, s, dir, progress);
}

template <int dim>
SimulationData simulate_mesh(const Staged<dim>& premeshed, const MeshSettings& s,
                             const vp::Scenario& scenario, const fs::path& dir,
                             const ProgressFunction& progress) {
  auto st = std::make_shared<Staged<dim>>(premeshed);
  const auto& img = st->image.image;
  vp::check_scenario_geometry<dim>(scenario, img.box_min(), img.box_max(), st->model.transform);
  vp::check_modulus_image<dim>(scenario, img);
  return simulate_dim<dim>(st, scenario, s, dir, progress);
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
    if (image.dim == 2)
      return mesh_data<2>(mesh_dim<2>(to_oriented<2>(image), image.source, settings, nullptr, progress));
    if (image.dim == 3)
      return mesh_data<3>(mesh_dim<3>(to_oriented<3>(image), image.source, settings, nullptr, progress));
    throw vp::InputError(image.source + ": the image must be 2D or 3D");
  });
}

void write_vtu(const MeshData& mesh, const std::string& path) {
  guarded([&] {
    if (mesh.state->two)
      vp::write_vtu(path, mesh.state->two->grid);
    else
      vp::write_vtu(path, mesh.state->three->grid);
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
    if (premeshed) {
      const MeshSettings s = with_scenario_mesh(settings, scenario);
      return dim == 2 ? simulate_mesh<2>(*premeshed->state->two, s, scenario, staging_dir, progress)
                      : simulate_mesh<3>(*premeshed->state->three, s, scenario, staging_dir, progress);
    }
    return dim == 2 ? simulate_image<2>(*image, settings, scenario, staging_dir, progress)
                    : simulate_image<3>(*image, settings, scenario, staging_dir, progress);
  });
}

std::string version() { return VIM_VERSION_STRING; }

}  // namespace vim::python

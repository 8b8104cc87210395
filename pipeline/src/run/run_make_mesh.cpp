// PipelineRun, stage 2 (pipeline_run.hpp): the mesh. The initial Kuhn/Freudenthal grid of the node
// budget, then the VIM optimisation (paper §IV; after a density-weighted E_G initialisation, §VI-E,
// with --sizing or mesh.needle_refinement) or the grid itself (--mesher grid), or one cell per voxel
// (--mesher voxel); segmentation (§VI-B); the mesh in world coordinates, built once here for mesh.vtu
// and every simulation step.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vim/adjacency.hpp>
#include <vim/energy.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/label_statistics.hpp>
#include <vim/pipeline/common/memory_limit.hpp>
#include <vim/pipeline/output/exports.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/quality.hpp>
#include <vim/segmentation.hpp>
#include <vim/sizing.hpp>
#include <vim/voxel_statistics.hpp>

#include "run/run_support.hpp"

namespace vim::pipeline {

namespace {

// Per-element values of a fixed mesh (the grid mesher) and its energies, as history[0].
template <int dim>
IterationRecord evaluate_fixed_mesh(const Image<dim>& image, MeshModel<dim>& model, const VimOptions& vo) {
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
  return r;
}

// VIM never makes an element below a lower bound, but it keeps those of the initial mesh until a move
// or swap repairs them (e.g. a grid on a very elongated box): the warning that says so, if any.
template <int dim>
std::optional<std::string> lower_bound_warning(const SimplexMesh<dim>& mesh, const VimOptions& vo,
                                               const MeshQuality& initial_quality) {
  long below = 0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    below += min_dihedral_deg<dim>(x) < vo.min_dihedral_deg ||
             (vo.min_radius_ratio > 0.0 && normalized_radius_ratio<dim>(x) < vo.min_radius_ratio);
  }
  if (below == 0) return std::nullopt;
  std::string bound;
  if (vo.min_dihedral_deg > 0.0) bound = fmt("--min-dihedral %g", vo.min_dihedral_deg);
  if (vo.min_radius_ratio > 0.0)
    bound += (bound.empty() ? "" : " or ") + fmt("--min-radius-ratio %g", vo.min_radius_ratio);
  return fmt(
      "%ld of %zu elements are below %s: the initial mesh already had such elements (smallest "
      "angle %.3g deg, radius ratio %.3g) and VIM only keeps or repairs them; use a smaller bound",
      below, mesh.n_cells(), bound.c_str(), initial_quality.min_dihedral_deg, initial_quality.min_nrr);
}

// A progress callback that logs each iteration of the optimiser and passes it on to `also`, if set.
std::function<void(const IterationRecord&)> vim_progress(
    int max_iterations, const std::function<void(const std::string&, const IterationRecord&)>& also) {
  const auto start = std::chrono::steady_clock::now();
  return [start, max_iterations, also](const IterationRecord& r) {
    if (also) also("vim", r);
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::string left;
    if (r.iteration > 0 && r.iteration < max_iterations)
      left = fmt(", at most ~%.0fs left", el / r.iteration * (max_iterations - r.iteration));
    Log::info("vim", fmt("iteration %d: E %.6f (E_G %.5g, E_D %.5g), v %.2e, moves %ld, swaps %ld, %.1fs%s",
                         r.iteration, r.energy, r.geometric, r.discretization, r.v, r.moves, r.swaps, el,
                         left.c_str()));
    if (r.iteration > 0)
      Log::detail("vim",
                  fmt("iteration %d: %ld nodes searched, %ld candidate positions evaluated, node updates "
                      "%.3fs, swap passes %.3fs",
                      r.iteration, r.searched, r.evaluations, r.node_seconds, r.swap_seconds));
  };
}

// Per label (docs/labels.md): its elements and their volume, its voxels' volume and the volume of those
// whose centre lies in an element of another label (the mesher's voxel enclosure, LabelStatistics).
template <int dim>
std::vector<LabelRecord> label_records(const Image<dim>& labels, const MeshModel<dim>& model) {
  const LabelStatistics<dim> stats(labels);
  const std::vector<int>& present = stats.labels();
  double voxel = 1.0;
  for (int a = 0; a < dim; ++a) voxel *= labels.spacing[a];
  std::vector<LabelRecord> out(present.size());
  for (std::size_t l = 0; l < present.size(); ++l) {
    out[l].label = present[l];
    const auto name = model.label_name.find(present[l]);
    out[l].name = name != model.label_name.end() ? name->second : "label_" + std::to_string(present[l]);
  }
  for (float v : labels.data)
    out[static_cast<std::size_t>(std::lower_bound(present.begin(), present.end(), static_cast<int>(v)) -
                                 present.begin())]
        .voxel_volume += voxel;
  std::vector<long> n;
  for (std::size_t c = 0; c < model.mesh.n_cells(); ++c) {
    const auto x = cell_points(model.mesh, c);
    const std::size_t own = static_cast<std::size_t>(
        std::lower_bound(present.begin(), present.end(), model.label[c]) - present.begin());
    out[own].elements += 1;
    out[own].volume += std::abs(signed_volume<dim>(x));
    stats.counts(x, n);
    for (std::size_t l = 0; l < present.size(); ++l)
      if (l != own) out[l].misclassified_volume += static_cast<double>(n[l]) * voxel;
  }
  return out;
}

}  // namespace

// Before the grid is built: VIM's node limit (3D facet keys pack 21 bits per node) and the memory.
template <int dim>
void PipelineRun<dim>::check_node_limit(const std::array<int, dim>& n, double voxels) const {
  const RunOptions& o = options_;
  double nodes = 1.0;
  std::string axes;
  for (int a = 0; a < dim; ++a) {
    nodes *= n[a];
    axes += (a ? "x" : "") + std::to_string(n[a]);
  }
  const double limit = static_cast<double>(Adjacency<dim>::max_points());
  const std::string given = o.spacing > 0.0 ? fmt("--spacing %g", o.spacing) : fmt("--nodes %ld", o.nodes);
  if (o.mesher == MesherKind::vim && nodes > limit)
    throw InputError(
        fmt("%s gives an initial grid of %s = %.0f nodes; VIM in %dD supports at most %.0f "
            "(facet keys pack %d bits per node): use %s",
            given.c_str(), axes.c_str(), nodes, dim, limit, dim == 3 ? 21 : 32,
            o.spacing > 0.0 ? "a larger --spacing" : "fewer --nodes"));
  check_memory_fits(voxels, nodes, o.max_memory);
}

template <int dim>
const MeshResult& PipelineRun<dim>::make_mesh() {
  const RunOptions& o = options_;
  MeshResult& result = mesh_result_;
  result.mesher = o.mesher;
  const Image<dim>& image = image_->image;
  const double voxels = static_cast<double>(image.voxel_count()) +
                        (sizing_ ? static_cast<double>(sizing_->image.voxel_count()) : 0.0);
  if (o.mesher == MesherKind::voxel) {
    check_memory_fits(voxels, static_cast<double>(image.voxel_count()), o.max_memory);  // a node per voxel
    // The fine voxel model: one quad/hexahedron per voxel.
    StageTimer t(result.timing, "voxel_grid");
    world_grid_ = std::make_shared<const UnstructuredGrid>(voxel_grid<dim>(image, model_.transform));
    t.stop();
    result.nodes = world_grid_->points.size();
    result.elements = world_grid_->n_cells();
    return result;
  }
  // Initial mesh: Kuhn/Freudenthal grid with the node budget (or spacing).
  StageTimer t_init(result.timing, "initial_mesh");
  const auto bmin = image.box_min(), bmax = image.box_max();
  nodes_per_axis_ = o.spacing > 0.0 ? nodes_per_axis_for_spacing<dim>(bmin, bmax, o.spacing)
                                    : nodes_per_axis_for_budget<dim>(bmin, bmax, o.nodes);
  check_node_limit(nodes_per_axis_, voxels);
  SimplexMesh<dim> initial = regular_grid_mesh<dim>(bmin, bmax, nodes_per_axis_);
  t_init.stop();
  std::string axes;
  for (int a = 0; a < dim; ++a) axes += (a ? "x" : "") + std::to_string(nodes_per_axis_[a]);
  Log::info("mesh", fmt("initial grid %s: %zu nodes, %zu elements", axes.c_str(), initial.n_points(),
                        initial.n_cells()));
  if (o.mesher == MesherKind::grid) {
    StageTimer t(result.timing, "voxel_statistics");
    model_.mesh = std::move(initial);
    const IterationRecord r = evaluate_fixed_mesh(image, model_, o.vim_options());
    if (labels_) {
      const LabelStatistics<dim> stats(*labels_);
      model_.label.resize(model_.mesh.n_cells());
      for (std::size_t c = 0; c < model_.mesh.n_cells(); ++c)
        model_.label[c] = stats.majority(cell_points(model_.mesh, c));
    }
    energy_history_ = {r};
    result.optimization = OptimizationRecord{0, false, r.geometric, r.discretization, {r}};
    t.stop();
  } else {
    optimize_mesh(std::move(initial));
  }
  if (o.threshold) segment_mesh();
  if (labels_) result.labels = label_records<dim>(*labels_, model_);
  if (!model_.label_modulus.empty()) {
    // The label table's moduli (the others: the element mean) for mesh.vtu and the exports of a run
    // without a scenario; build_model replaces them by the moduli simulated.
    model_.youngs_modulus.resize(model_.mesh.n_cells());
    for (std::size_t c = 0; c < model_.mesh.n_cells(); ++c) {
      const auto it = model_.label_modulus.find(model_.label[c]);
      model_.youngs_modulus[c] = it != model_.label_modulus.end() ? it->second : model_.values[c].mean;
    }
  }
  result.nodes = model_.mesh.n_points();
  result.elements = model_.mesh.n_cells();
  result.nodes_per_axis.assign(nodes_per_axis_.begin(), nodes_per_axis_.end());
  result.quality = mesh_quality(model_.mesh);
  // The mesh in world coordinates, once: mesh.vtu, the exports and every simulation step use it.
  world_mesh_ = world_mesh<dim>(model_);
  world_grid_ = std::make_shared<const UnstructuredGrid>(simplex_grid<dim>(world_mesh_));
  return result;
}

// VIM optimisation (paper §IV). The needle density is kept during VIM; a --sizing image only
// initialises (paper §VI-E, Fig. 13).
template <int dim>
void PipelineRun<dim>::optimize_mesh(SimplexMesh<dim> initial) {
  const RunOptions& o = options_;
  const Image<dim>& image = image_->image;
  const VimOptions vo = o.vim_options();
  const Image<dim>* density = needle_density_ ? &*needle_density_ : nullptr;
  if (sizing_ || density) {
    // E_G-only initialisation weighted by the density image (§VI-E), then VIM from there.
    StageTimer ts(mesh_result_.timing, "sizing");
    const auto sizing_start = std::chrono::steady_clock::now();
    auto sizing_progress = [&](const IterationRecord& r) {
      if (inputs_ && inputs_->on_iteration) inputs_->on_iteration("sizing", r);
      const double el =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - sizing_start).count();
      Log::info("sizing",
                fmt("iteration %d: density-weighted E_G %.5g (%.4f of the start), v %.2e, moves %ld, "
                    "swaps %ld, %.1fs",
                    r.iteration, r.geometric, r.energy, r.v, r.moves, r.swaps, el));
    };
    initial = size_initial_mesh<dim>(sizing_ ? sizing_->image : *density, std::move(initial),
                                     vo.max_iterations, vo, sizing_progress);
    Log::info("sizing", fmt("density-weighted initialisation from %s done",
                            sizing_ ? o.sizing.c_str() : "mesh.needle_refinement"));
    ts.stop();
  }
  StageTimer t(mesh_result_.timing, "optimize");
  const bool lower_bound = vo.min_dihedral_deg > 0.0 || vo.min_radius_ratio > 0.0;
  const MeshQuality initial_quality = lower_bound ? mesh_quality(initial) : MeshQuality{};
  const auto progress = vim_progress(vo.max_iterations, inputs_ ? inputs_->on_iteration : nullptr);
  // With --labels the label energy (docs/labels.md); the element values are IMAGE's (Eq. 4–6).
  VimResult<dim> result =
      labels_ ? optimize_labels<dim>(*labels_, std::move(initial), vo, progress, density, &image)
              : optimize<dim>(image, std::move(initial), vo, progress, density);
  model_.label = std::move(result.labels);
  t.stop();
  if (result.ed0_estimated) {
    warn(mesh_result_.warnings, "vim",
         fmt("no element of the initial mesh holds voxel centres of different values (E_D = 0 at the start; "
             "%zu nodes for %zu voxels: the elements are about as small as the voxels or smaller, or their "
             "faces lie on the image's edges), so E_D0 is estimated as |box| var(image) m^(-1/%d) = %.4g for "
             "m elements and the image term keeps the fit; with elements smaller than the voxels, fewer "
             "--nodes give the image more to shape",
             result.mesh.n_points(), image.voxel_count(), dim, result.ed0));
  } else if (result.ed0 == 0.0 && vo.lambda > 0.0) {
    warn(mesh_result_.warnings, "vim",
         "the image is constant inside the box (E_D0 = 0): the mesh is optimised for E_G only");
  }
  model_.mesh = std::move(result.mesh);
  if (lower_bound)
    if (const auto w = lower_bound_warning(model_.mesh, vo, initial_quality))
      warn(mesh_result_.warnings, "vim", *w);
  model_.values = std::move(result.values);
  energy_history_ = result.history;
  mesh_result_.optimization = OptimizationRecord{result.history.empty() ? 0 : result.history.back().iteration,
                                                 result.converged, result.eg0, result.ed0, result.history};
}

// Segmentation (§VI-B): face-connected components of the elements whose mean is above --threshold;
// the largest by volume is the object.
template <int dim>
void PipelineRun<dim>::segment_mesh() {
  const double threshold = *options_.threshold;
  StageTimer t(mesh_result_.timing, "segment");
  const Segmentation seg = segment<dim>(model_.mesh, model_.values, threshold);
  model_.segment = seg.component;
  model_.object.assign(seg.object.begin(), seg.object.end());
  double volume = 0.0;
  long voxels = 0;
  for (std::size_t c = 0; c < model_.mesh.n_cells(); ++c)
    if (seg.object[c]) {
      volume += std::abs(signed_volume(model_.mesh, c));
      voxels += model_.values[c].voxels;
    }
  mesh_result_.segmentation =
      SegmentationRecord{threshold, seg.n_components, seg.largest_size, volume, voxels};
  t.stop();
}

template <int dim>
const MeshResult& PipelineRun<dim>::reuse_mesh(const PipelineRun& meshed) {
  if (options_.mesher == MesherKind::voxel || meshed.options_.mesher == MesherKind::voxel)
    throw std::invalid_argument("PipelineRun::reuse_mesh: the voxel model has no simplex mesh to reuse");
  model_ = meshed.model_;
  nodes_per_axis_ = meshed.nodes_per_axis_;
  energy_history_ = meshed.energy_history_;
  world_mesh_ = meshed.world_mesh_;
  world_grid_ = meshed.world_grid_;
  needle_density_.reset();  // the mesh is made: mesh.needle_refinement no longer applies
  inputs_result_.needle_refinement.reset();
  if (meshed.inputs_result_.sizing) inputs_result_.sizing = meshed.inputs_result_.sizing;
  mesh_result_ = meshed.mesh_result_;  // its record and times
  // The meshing run's warnings that this run has not given again (read_inputs' repeat).
  mesh_result_.warnings.clear();
  for (const std::string& w : meshed.warnings()) {
    const auto given = [&](const std::vector<std::string>& list) {
      return std::find(list.begin(), list.end(), w) != list.end();
    };
    if (!given(inputs_result_.warnings) && !given(mesh_result_.warnings)) mesh_result_.warnings.push_back(w);
  }
  return mesh_result_;
}

template const MeshResult& PipelineRun<2>::make_mesh();
template const MeshResult& PipelineRun<3>::make_mesh();
template const MeshResult& PipelineRun<2>::reuse_mesh(const PipelineRun<2>&);
template const MeshResult& PipelineRun<3>::reuse_mesh(const PipelineRun<3>&);

}  // namespace vim::pipeline

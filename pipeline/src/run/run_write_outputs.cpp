// PipelineRun, stage 5 (pipeline_run.hpp): mesh.vtu (the world grid of make_mesh with the per-element
// fields), the --export formats and the figures.
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/output/exports.hpp>
#include <vim/pipeline/output/figures.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/quality.hpp>

namespace vim::pipeline {

// The world grid with the fields of mesh.vtu: the voxel values, or per element the mean, variance,
// voxel count, quality (3D: max dihedral angle, 2D: min angle), segment and object, the modulus of the
// simulation, and per node the number of box faces it lies on.
template <int dim>
UnstructuredGrid PipelineRun<dim>::mesh_vtu_grid() const {
  UnstructuredGrid grid = *world_grid_;
  if (options_.mesher == MesherKind::voxel) {
    const Image<dim>& image = image_->image;
    grid.cell_data["value"] = Field{1, std::vector<double>(image.data.begin(), image.data.end())};
    return grid;
  }
  const std::size_t nc = model_.mesh.n_cells();
  Field mean{1, {}}, variance{1, {}}, voxels{1, {}}, quality{1, {}};
  for (std::size_t c = 0; c < nc; ++c) {
    mean.values.push_back(model_.values[c].mean);
    variance.values.push_back(model_.values[c].variance);
    voxels.values.push_back(static_cast<double>(model_.values[c].voxels));
    const auto x = cell_points(model_.mesh, c);
    quality.values.push_back(dim == 3 ? max_dihedral_deg<dim>(x) : min_dihedral_deg<dim>(x));
  }
  grid.cell_data["mean"] = std::move(mean);
  grid.cell_data["variance"] = std::move(variance);
  grid.cell_data["voxels"] = std::move(voxels);
  grid.cell_data["quality"] = std::move(quality);
  if (!model_.segment.empty()) {
    grid.cell_data["segment"] = Field{1, std::vector<double>(model_.segment.begin(), model_.segment.end())};
    grid.cell_data["object"] = Field{1, std::vector<double>(model_.object.begin(), model_.object.end())};
  }
  if (model_.youngs_modulus.size() == nc) grid.cell_data["youngs_modulus"] = Field{1, model_.youngs_modulus};
  if (model_.label.size() == nc)
    grid.cell_data["label"] = Field{1, std::vector<double>(model_.label.begin(), model_.label.end())};
  const auto bmin = image_->image.box_min(), bmax = image_->image.box_max();
  const auto kind = boundary_kind<dim>(model_.mesh, bmin, bmax, 1e-9 * (bmax - bmin).norm());
  grid.point_data["boundary"] = Field{1, std::vector<double>(kind.begin(), kind.end())};
  return grid;
}

template <int dim>
const OutputsResult& PipelineRun<dim>::write_outputs() {
  const RunOptions& o = options_;
  OutputsResult& result = outputs_result_;
  StageTimer t_write(result.timing, "write");
  write_vtu(out().file("mesh.vtu"), mesh_vtu_grid());
  if (o.mesher == MesherKind::voxel) {
    if (!o.exports.empty()) {
      // The exports and figures are for simplex meshes: say so instead of skipping them silently.
      result.exports = nlohmann::json{
          {"skipped",
           "--mesher voxel writes its hexahedra to mesh.vtu only (no --export formats, no figures)"}};
      Log::info(
          "write",
          "--mesher voxel: mesh.vtu only (the --export formats and figures are for the simplex meshes)");
    }
    t_write.stop();
    return result;
  }
  // Exports for other tools (world coordinates, material bins).
  if (!o.exports.empty()) {
    for (const auto& f : o.exports)
      if (export_format(f).writes(dim)) out().file("mesh." + f);
    // .feb and .inp carry ν: the scenario's when there is one, else kDefaultPoissonRatio (0.49).
    // With a scenario they are complete solver jobs: its conditions, ν and element degree (build_model
    // set model_.youngs_modulus to the modulus simulated).
    ExportOptions export_options;
    if (scenario_) {
      export_options.poisson_ratio = scenario_->poisson_ratio;
      export_options.scenario = &*scenario_;
      export_options.degree = static_cast<unsigned>(o.degree);
    }
    nlohmann::json exports =
        write_exports<dim>(ExportInput<dim>{model_, world_mesh_, export_options}, out().path(), o.exports);
    for (const auto& w : exports.value("warnings", nlohmann::json::array()))
      warn(result.warnings, "export", w.get<std::string>());
    for (auto& [format, path] : exports["files"].items()) path = "mesh." + format;
    result.exports = std::move(exports);
  }
  if (dim == 3)
    for (const char* name : {"sagittal", "coronal", "axial"})
      out().file(std::string("figures/slice_") + name + ".png");
  else
    for (const char* name : {"mesh_overlay", "discretized"})
      out().file(std::string("figures/") + name + ".png");
  result.mesh_figures = write_mesh_figures<dim>(*image_, model_, out().path());
  if (mesh_result_.optimization && energy_history_.size() >= 2)
    result.energy_figure = write_energy_plot(energy_history_, out().file("figures/energy.png"));
  t_write.stop();
  return result;
}

template const OutputsResult& PipelineRun<2>::write_outputs();
template const OutputsResult& PipelineRun<3>::write_outputs();
}  // namespace vim::pipeline

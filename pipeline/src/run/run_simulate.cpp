// PipelineRun, stages 3 and 4 (pipeline_run.hpp): the FEM model of the scenario on the mesh (or on the
// voxels) and the needle insertion on it (simulation.hpp), with its figures. Both do nothing without
// --simulate.
#include <chrono>
#include <vim/pipeline/common/memory_limit.hpp>
#include <vim/pipeline/output/figures.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/seconds_since.hpp>

namespace vim::pipeline {

using nlohmann::json;

template <int dim>
void PipelineRun<dim>::build_model() {
  if (!scenario_) return;
  const auto start = std::chrono::steady_clock::now();
  SimulationOptions so;
  if (out_) so.output_file = [this](const std::string& rel) { return out().file(rel); };
  if (!out_ && !ranks_.pieces_out.empty())
    so.piece_file = [dir = ranks_.pieces_out](const std::string& rel) { return dir / rel; };
  so.degree = static_cast<unsigned>(options_.degree);
  so.world_grid = world_grid_;  // the grid of mesh.vtu: the steps share its points and cells
  so.scenario_checked = true;   // read_inputs checked it against the image box
  so.keep_step_fields = inputs_ && inputs_->keep_step_fields;
  so.compare_linear = options_.compare_linear;
  so.mpi_ranks = ranks_.size;
  so.mpi_comm = ranks_.comm;
  // --max-memory per process; by default the ranks share the memory available to this one
  if (ranks_.size > 1)
    so.max_memory = options_.max_memory > 0.0 ? options_.max_memory
                                              : available_memory_bytes().value_or(0.0) / ranks_.size;
  if (options_.mesher == MesherKind::voxel) {
    simulation_ = std::make_unique<NeedleSimulation<dim>>(NeedleSimulation<dim>::voxel(
        image_->image, model_.transform, *scenario_, std::move(so), model_.label_image));
  } else {
    // Validates the scenario against the mesh (regions that select no node, targets outside it).
    simulation_ = std::make_unique<NeedleSimulation<dim>>(model_, *scenario_, std::move(so));
    model_.youngs_modulus = simulation_->youngs_modulus();  // mesh.vtu carries the modulus used
  }
  simulate_result_.seconds = seconds_since(start);
}

template <int dim>
const SimulateResult& PipelineRun<dim>::simulate() {
  if (!simulation_) return simulate_result_;
  const auto start = std::chrono::steady_clock::now();
  simulation_result_ = std::make_unique<const SimulationResult<dim>>(simulation_->run());
  const SimulationResult<dim>& result = *simulation_result_;
  simulate_result_.simulation = result.report;
  for (const auto& w : result.warnings) warn(simulate_result_.warnings, "simulate", w);
  if (out_) simulate_result_.figures = write_simulation_figures(result);
  simulate_result_.seconds += seconds_since(start);
  return simulate_result_;
}

// Figures of a needle run: axial/lateral force against depth and the needle's path for every needle and, on a
// simplex model, the deformed mesh at the last step cut through the final tip position; of a static load case
// the deformed mesh cut through the model's centre (3D: normal to the first axis).
template <int dim>
json PipelineRun<dim>::write_simulation_figures(const SimulationResult<dim>& result) {
  json figures = json::object();
  const MeshModel<dim>* model = options_.mesher == MesherKind::voxel ? nullptr : &model_;
  // Axis titles in the scenario's units: force = modulus × length² (kPa·mm² = mN; in 2D per unit
  // thickness).
  std::string length = "mm", modulus = "kPa";
  if (result.report.contains("units")) {
    length = result.report["units"].value("length", length);
    modulus = result.report["units"].value("modulus", modulus);
  }
  const std::string force = length == "mm" && modulus == "kPa" ? "mN" : modulus + "·" + length + "²";
  if (model && result.static_load) {
    // A static load case: the deformed mesh, cut through the centre of the model normal to its first axis.
    std::vector<Eigen::Matrix<double, dim, 1>> u;
    for (const auto& w : result.static_load->vertex_displacement)
      u.push_back(model->transform.vector_to_frame(w));
    Eigen::Matrix<double, dim, 1> lo = model->mesh.points.front(), hi = lo;
    for (const auto& p : model->mesh.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    json& fig = figures["static_load"];
    fig = write_deformed_slice<dim>(*model, u, out().file("figures/deformed.png"), 0.5 * (lo + hi), 0,
                                    "|u| [" + length + "]");
    fig["file"] = "figures/deformed.png";
  }
  for (const auto& run : result.needles) {
    if (run.depth.empty()) continue;
    const std::string prefix = result.needles.size() > 1 ? run.name + "_" : "";
    json& fig = figures[run.name.empty() ? std::string("needle") : run.name];
    fig["force"] = write_line_plot(out().file("figures/" + prefix + "needle_force.png"), run.depth,
                                   {run.axial_force, run.friction_force, run.tip_force, run.lateral_force},
                                   {"axial force", "friction", "tip", "lateral force"},
                                   "needle depth [" + length + "]", "force on the needle [" + force + "]");
    fig["force"]["file"] = "figures/" + prefix + "needle_force.png";
    if (!run.target_displacement.empty() && !run.target_displacement.front().empty()) {
      std::vector<std::vector<double>> series(run.target_displacement.front().size());
      for (const auto& step : run.target_displacement)
        for (std::size_t t = 0; t < step.size() && t < series.size(); ++t)
          series[t].push_back(step[t].norm());
      std::vector<std::string> names;
      for (std::size_t t = 0; t < series.size(); ++t)
        names.push_back(t < result.target_names.size() ? result.target_names[t]
                                                       : "target " + std::to_string(t + 1));
      fig["targets"] =
          write_line_plot(out().file("figures/" + prefix + "target_displacement.png"), run.depth, series,
                          names, "needle depth [" + length + "]", "target displacement |u| [" + length + "]");
      fig["targets"]["file"] = "figures/" + prefix + "target_displacement.png";
    }
    {  // the needle's path in views normal to its planned line, with the targets
      std::vector<Eigen::Matrix<double, dim, 1>> moved;
      for (std::size_t t = 0; t < result.target_positions.size(); ++t)
        moved.push_back(result.target_positions[t] + run.target_displacement.back().at(t));
      const auto shape = run.shape.empty()
                             ? std::vector<Eigen::Matrix<double, dim, 1>>{run.entry, run.tip.back()}
                             : run.shape.back();
      fig["path"] =
          write_needle_path_figure<dim>(out().file("figures/" + prefix + "needle_path.png"), run.entry,
                                        run.axis, shape, run.tip, result.target_positions, moved, length);
      fig["path"]["file"] = "figures/" + prefix + "needle_path.png";
    }
    if (model && !run.vertex_displacement.empty() &&
        run.vertex_displacement.back().size() == model->mesh.n_points()) {
      std::vector<Eigen::Matrix<double, dim, 1>> u;
      u.reserve(model->mesh.n_points());
      for (const auto& w : run.vertex_displacement.back()) u.push_back(model->transform.vector_to_frame(w));
      const Eigen::Matrix<double, dim, 1> tip = model->transform.to_frame(run.tip.back());
      int normal = dim - 1;  // 3D: the slice through the tip that holds the most of the needle
      if constexpr (dim == 3) normal = slice_normal_along(model->transform.vector_to_frame(run.axis));
      fig["deformed"] = write_deformed_slice<dim>(*model, u, out().file("figures/" + prefix + "deformed.png"),
                                                  tip, normal, "|u| [" + length + "]");
      fig["deformed"]["file"] = "figures/" + prefix + "deformed.png";
    }
  }
  std::vector<Eigen::Matrix<double, dim, 1>> planned, final_position;  // a procedure's seeds
  for (const auto& run : result.needles)
    for (const auto& seed : run.seeds) {
      planned.push_back(seed.planned);
      final_position.push_back(seed.final_position());
    }
  if (!planned.empty()) {
    figures["seeds"] =
        write_seed_figure<dim>(out().file("figures/seeds.png"), planned, final_position, length);
    figures["seeds"]["file"] = "figures/seeds.png";
  }
  return figures;
}

template void PipelineRun<2>::build_model();
template void PipelineRun<3>::build_model();
template const SimulateResult& PipelineRun<2>::simulate();
template const SimulateResult& PipelineRun<3>::simulate();

}  // namespace vim::pipeline

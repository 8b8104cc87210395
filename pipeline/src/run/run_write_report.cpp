// PipelineRun, stage 6 (pipeline_run.hpp): report.json, made once from the results of the stages
// (stage_results.hpp) and listing every file of the run; then the output folder is committed (kept) and
// the summary goes to stdout.
#include <chrono>
#include <iostream>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/version.hpp>

#include "run/run_support.hpp"

namespace vim::pipeline {

using nlohmann::json;

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
  j["max_memory"] = o.max_memory > 0.0 ? json(o.max_memory) : json(nullptr);
  j["degree"] = o.degree;
  j["simulate"] = o.simulate.empty() ? json(nullptr) : json(o.simulate);
  j["export"] = o.exports;
  j["overwrite"] = o.overwrite;
  return j;
}

namespace {

json mesh_json(const MeshResult& m) {
  json j = {{"mesher", to_string(m.mesher)}, {"nodes", m.nodes}, {"elements", m.elements}};
  if (m.mesher == MesherKind::voxel) return j;
  j["nodes_per_axis"] = m.nodes_per_axis;
  if (m.quality) j["quality"] = quality_json(*m.quality);
  return j;
}

json optimization_json(const OptimizationRecord& o) {
  return {{"iterations", o.iterations},
          {"converged", o.converged},
          {"eg0", o.eg0},
          {"ed0", o.ed0},
          {"history", history_json(o.history)}};
}

json segmentation_json(const SegmentationRecord& s) {
  return {{"threshold", s.threshold},
          {"components", s.components},
          {"object_elements", s.object_elements},
          {"object_volume", s.object_volume},
          {"object_voxels", s.object_voxels}};
}

}  // namespace

template <int dim>
std::vector<std::string> PipelineRun<dim>::warnings() const {
  std::vector<std::string> all;
  for (const auto* list : {&inputs_result_.warnings, &mesh_result_.warnings, &simulate_result_.warnings,
                           &outputs_result_.warnings})
    all.insert(all.end(), list->begin(), list->end());
  return all;
}

template <int dim>
json PipelineRun<dim>::report() const {
  json r = {
      {"tool",
       {{"name", inputs_ ? inputs_->tool : std::string("vim-pipeline")}, {"version", VIM_VERSION_STRING}}},
      {"command_line", options_.command_line},
      {"options", options_json(options_)},
      {"out", options_.out.string()}};
  json timing = json::object();
  const auto add_times = [&](const std::vector<StageTime>& times) {
    for (const StageTime& t : times) timing[t.stage] = t.seconds;
  };
  // read_inputs
  const InputsResult& in = inputs_result_;
  if (!in.image.is_null()) r["input"] = in.image;
  if (in.sizing) r["sizing"] = *in.sizing;
  if (in.labels) r["labels"] = *in.labels;
  if (in.needle_refinement)
    r["needle_refinement"] = {{"size_ratio", in.needle_refinement->size_ratio},
                              {"radius", in.needle_refinement->radius},
                              {"peak_density", in.needle_refinement->peak_density}};
  add_times(in.timing);
  // make_mesh or reuse_mesh
  const MeshResult& mesh = mesh_result_;
  if (mesh.elements > 0) r["mesh"] = mesh_json(mesh);
  if (mesh.optimization) r["optimization"] = optimization_json(*mesh.optimization);
  if (mesh.segmentation) r["segmentation"] = segmentation_json(*mesh.segmentation);
  if (!mesh.labels.empty()) {
    json labels = json::array();
    for (const LabelRecord& l : mesh.labels)
      labels.push_back({{"label", l.label},
                        {"name", l.name},
                        {"elements", l.elements},
                        {"volume", l.volume},
                        {"voxel_volume", l.voxel_volume},
                        {"misclassified_volume", l.misclassified_volume}});
    r["mesh"]["labels"] = labels;
  }
  add_times(mesh.timing);
  // simulate
  if (simulation_result_) {
    r["simulation"] = simulate_result_.simulation;
    if (!simulate_result_.figures.empty()) r["figures"]["simulation"] = simulate_result_.figures;
    timing["simulate"] = simulate_result_.seconds;
  }
  // write_outputs
  const OutputsResult& outputs = outputs_result_;
  if (outputs.exports) r["exports"] = *outputs.exports;
  if (outputs.mesh_figures) r["figures"]["mesh"] = *outputs.mesh_figures;
  if (outputs.energy_figure) r["figures"]["energy"] = *outputs.energy_figure;
  add_times(outputs.timing);
  // write_report
  if (report_result_) {
    timing["total"] = report_result_->total_seconds;
    r["outputs"] = report_result_->outputs;
  }
  if (!timing.empty()) r["timing"] = timing;
  const std::vector<std::string> all = warnings();
  if (!all.empty()) r["warnings"] = all;
  return r;
}

template <int dim>
const ReportResult& PipelineRun<dim>::write_report() {
  ReportResult result;
  result.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  out().file("report.json");
  result.outputs = out().files();
  report_result_ = std::move(result);
  const json report = this->report();
  write_text_atomically(out().path() / "report.json", [&](std::ostream& s) { s << report.dump(2) << "\n"; });
  out().commit();
  if (options_.verbosity != Verbosity::quiet) print_summary(std::cout, report);
  return *report_result_;
}

template std::vector<std::string> PipelineRun<2>::warnings() const;
template std::vector<std::string> PipelineRun<3>::warnings() const;
template json PipelineRun<2>::report() const;
template json PipelineRun<3>::report() const;
template const ReportResult& PipelineRun<2>::write_report();
template const ReportResult& PipelineRun<3>::write_report();

}  // namespace vim::pipeline

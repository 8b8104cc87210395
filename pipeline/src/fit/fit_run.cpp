// The --fit-forces run (fit_run.hpp).
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/common/output_directory.hpp>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/fit/fit_run.hpp>
#include <vim/pipeline/fit/force_fit.hpp>
#include <vim/pipeline/output/figures.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>

namespace vim::pipeline {

namespace {

using nlohmann::json;

json fit_json(const RunOptions& o, const MeasuredCurve& m, const FitResult& r) {
  json j;
  j["measured"] = o.fit_forces;
  j["scenario"] = o.simulate;
  j["fitted_scenario"] = "fitted.yaml";
  json parameters = json::array();
  for (const FitParameter& p : r.parameters)
    parameters.push_back(
        {{"name", p.name}, {"start", p.start}, {"value", p.value}, {"standard_error", p.standard_error}});
  j["parameters"] = parameters;
  j["rms_residual"] = r.rms_residual;
  j["iterations"] = r.iterations;
  j["simulations"] = r.simulations;
  j["converged"] = r.converged;
  j["termination"] = r.termination;
  j["curve"] = {{"depth", m.depth}, {"measured", m.force}, {"fitted", r.fitted_force}};
  return j;
}

template <int dim>
void fit_image(const RunOptions& o, ImageFile file) {
  const MeasuredCurve measured = read_measured_forces(o.fit_forces);
  OutputDirectory out(o.out, o.overwrite);  // refuses a non-empty DIR before any work
  RunOptions mesh_options = o;
  mesh_options.out.clear();  // the meshing run writes nothing
  RunInputs<dim> mesh_inputs;
  mesh_inputs.image = file.read<dim>();
  if (!o.sizing.empty()) mesh_inputs.sizing = read_image<dim>(o.sizing);
  mesh_inputs.scenario = read_scenario(o.simulate, dim);
  PipelineRun<dim> mesh(mesh_options, std::move(mesh_inputs));
  mesh.read_inputs();
  mesh.make_mesh();
  const Scenario& scenario = *mesh.scenario();
  fit_parameters(scenario);  // nothing to fit: fails before any simulation
  const auto simulate = [&](const Scenario& s) {
    SimulationOptions so;
    so.degree = static_cast<unsigned>(mesh.options().degree);
    so.progress = false;
    so.step_fields = false;
    so.scenario_checked = true;
    const bool voxel = o.mesher == MesherKind::voxel;
    NeedleSimulation<dim> sim = voxel
                                    ? NeedleSimulation<dim>::voxel(mesh.image().image, mesh.model().transform,
                                                                   s, so, mesh.model().label_image)
                                    : NeedleSimulation<dim>(mesh.model(), s, so);
    const SimulationResult<dim> result = sim.run();
    return ForceCurve{result.needles.front().depth, result.needles.front().axial_force};
  };
  Log::info("fit", "fitting the needle to " + o.fit_forces + " (" + std::to_string(measured.depth.size()) +
                       " rows)");
  const FitResult fit = fit_forces(scenario, measured, simulate);
  const std::string fitted_path = (o.out / "fitted.yaml").string();
  Scenario fitted = with_parameters(scenario, fit.parameters);
  fitted.source = fitted_path;
  write_text_atomically(out.file("fitted.yaml"), [&](std::ostream& s) { s << fitted.text; });
  write_text_atomically(out.file("fit.json"),
                        [&](std::ostream& s) { s << fit_json(o, measured, fit).dump(2) << "\n"; });
  const std::string force = fitted.length_unit == "mm" && fitted.modulus_unit == "kPa"
                                ? "mN"
                                : fitted.modulus_unit + "·" + fitted.length_unit + "²";
  write_line_plot(out.file("figures/force_fit.png"), measured.depth, {measured.force, fit.fitted_force},
                  {"measured", "fitted"}, "needle depth [" + fitted.length_unit + "]",
                  "axial force [" + force + "]");
  // The fitted scenario, as --simulate runs it, into the same folder.
  RunOptions run_options = o;
  run_options.simulate = fitted_path;
  run_options.overwrite = true;  // the fit's files are there
  RunInputs<dim> inputs;
  inputs.image = mesh.image();
  inputs.scenario = fitted;
  PipelineRun<dim> run(run_options, std::move(inputs));
  run.read_inputs();
  if (o.mesher == MesherKind::voxel)
    run.make_mesh();
  else
    run.reuse_mesh(mesh);
  run.build_model();
  run.simulate();
  run.write_outputs();
  run.write_report();
  out.commit();
}

}  // namespace

void run_force_fit(const RunOptions& o) {
  ImageFile file(o.image);
  if (file.dimension() == 2)
    fit_image<2>(o, std::move(file));
  else
    fit_image<3>(o, std::move(file));
}

}  // namespace vim::pipeline

// The static load case of a scenario without a needle (static_load.hpp).
#include "simulation/static_load.hpp"

#include <optional>
#include <vim/fem/finite_strain.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "simulation/largest_strain.hpp"
#include "simulation/simulation_output.hpp"

namespace vim::pipeline {

using json = nlohmann::json;

namespace {

// material.model neo-hookean: the Newton solve of the model's conditions, its load steps for the report
// (load factor, per iteration ‖r‖ on the free DoFs and the update's norm) in `newton`.
template <int dim>
fem::Solution<dim> solve_finite_strain(SimulationContext<dim>& ctx, json& newton) {
  const Scenario& sc = ctx.sc;
  if (ctx.opt.mpi_ranks > 1)
    throw ScenarioError(sc.where(sc.material_model_line) +
                        "material.model = 'neo-hookean' is solved on one process; run without --mpi-ranks");
  fem::FiniteStrainSolution<dim> fs;
  try {
    fs = fem::solve_neo_hookean(*ctx.model);
  } catch (const fem::NewtonFailure& e) {
    throw ScenarioError(sc.where(sc.material_model_line) + "material.model = 'neo-hookean': " + e.what());
  }
  json steps = json::array();
  for (const fem::LoadStepRecord& s : fs.steps)
    steps.push_back({{"load_factor", s.load_factor},
                     {"residual_norm", s.residual_norm},
                     {"update_norm", s.update_norm},
                     {"line_search", s.line_search}});
  newton = {{"load_steps", steps}, {"iterations", fs.newton_iterations}, {"halvings", fs.halvings}};
  return fs.solution;
}

// What --compare-linear compares of one model's solve, in world axes: the targets' displacements (sampled
// right after that solve), each displacement condition's reaction and the largest vertex displacement.
template <int dim>
struct ComparedState {
  std::vector<Eigen::Matrix<double, dim, 1>> targets, reactions;
  double max_displacement = 0.0;
};

template <int dim>
ComparedState<dim> compared_state(SimulationContext<dim>& ctx, const fem::Solution<dim>& s,
                                  const std::vector<Eigen::Matrix<double, dim, 1>>& targets) {
  ComparedState<dim> out;
  if (!targets.empty())
    for (const auto& u : ctx.model->sample(targets)) out.targets.push_back(ctx.tf.vector_to_world(u));
  for (const auto& r : s.dirichlet_reaction) out.reactions.push_back(ctx.tf.vector_to_world(r));
  for (const auto& u : s.vertex_displacement) out.max_displacement = std::max(out.max_displacement, u.norm());
  return out;
}

// report.json simulation.compare_linear: per target, per displacement condition (its reaction) and for
// the largest displacement both models' values and |linear − neo-Hookean| / |neo-Hookean| (null where
// the neo-Hookean value is below 1e-6 of the largest of its kind: a held target, an unloaded condition).
template <int dim>
json compare_linear_report(const Scenario& sc, const ComparedState<dim>& lin, const ComparedState<dim>& nh) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  const auto array = [](const Vec& v) {
    json a = json::array();
    for (int c = 0; c < dim; ++c) a.push_back(v[c]);
    return a;
  };
  const auto entry = [&](const Vec& l, const Vec& n, double largest) {
    json e = {{"linear", array(l)}, {"neo-hookean", array(n)}, {"relative_difference", nullptr}};
    if (n.norm() > 1e-6 * largest) e["relative_difference"] = (l - n).norm() / n.norm();
    return e;
  };
  double largest_target = 0.0, largest_reaction = 0.0;
  for (const Vec& u : nh.targets) largest_target = std::max(largest_target, u.norm());
  for (const Vec& r : nh.reactions) largest_reaction = std::max(largest_reaction, r.norm());
  json targets = json::object(), reactions = json::array();
  for (std::size_t t = 0; t < nh.targets.size(); ++t)
    targets[sc.targets[t].name] = entry(lin.targets[t], nh.targets[t], largest_target);
  std::size_t k = 0;  // the model's Dirichlet conditions are the scenario's in order
  for (std::size_t i = 0; i < sc.boundary_conditions.size() && k < nh.reactions.size(); ++i) {
    const auto& bc = sc.boundary_conditions[i];
    if (bc.support == BoundaryConditionSpec::Support::elastic || !bc.is_dirichlet()) continue;
    json e = entry(lin.reactions[k], nh.reactions[k], largest_reaction);
    e["condition"] = "boundary_conditions[" + std::to_string(i) + "]";
    e["region"] = bc.region.describe();
    reactions.push_back(std::move(e));
    ++k;
  }
  return {{"definition", "|linear - neo-hookean| / |neo-hookean|"},
          {"targets", targets},
          {"reactions", reactions},
          {"max_displacement",
           {{"linear", lin.max_displacement},
            {"neo-hookean", nh.max_displacement},
            {"relative_difference",
             std::abs(lin.max_displacement - nh.max_displacement) / std::max(nh.max_displacement, 1e-300)}}}};
}

}  // namespace

template <int dim>
StaticLoadOutcome<dim> run_static_load(SimulationContext<dim>& ctx, std::vector<std::string>& warnings) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  const auto start = Clock::now();
  const bool finite_strain = ctx.sc.material_model == Scenario::MaterialModel::neo_hookean;
  fem::Solution<dim> solution;
  json newton, compared;
  std::vector<Vec> targets;
  for (const auto& t : ctx.sc.targets) targets.push_back(ctx.tf.to_frame(spec_vector<dim>(t.position)));
  try {
    std::optional<ComparedState<dim>> other;  // --compare-linear: the other model, solved first
    if (ctx.opt.compare_linear) {
      json unused;
      const fem::Solution<dim> s =
          finite_strain ? ctx.model->solve({}, ctx.solver) : solve_finite_strain<dim>(ctx, unused);
      other = compared_state<dim>(ctx, s, targets);
    }
    solution = finite_strain ? solve_finite_strain<dim>(ctx, newton) : ctx.model->solve({}, ctx.solver);
    if (other) {
      const ComparedState<dim> own = compared_state<dim>(ctx, solution, targets);
      compared = finite_strain ? compare_linear_report<dim>(ctx.sc, *other, own)
                               : compare_linear_report<dim>(ctx.sc, own, *other);
    }
  } catch (const fem::SingularConstraints& e) {  // name the scenario's conditions, as a needle run does
    const int line = ctx.sc.boundary_conditions.empty() ? 0 : ctx.sc.boundary_conditions.front().line;
    throw ScenarioError(ctx.sc.where(line) + "boundary_conditions: " + e.what());
  }
  const double solve_seconds = seconds_since(start);
  StaticLoadRun<dim> run;
  run.stats = solution.stats;
  for (const Vec& u : solution.vertex_displacement) {
    run.vertex_displacement.push_back(ctx.tf.vector_to_world(u));
    run.max_displacement = std::max(run.max_displacement, u.norm());
  }
  run.max_strain = largest_principal_strain<dim>(solution.cell_strain);
  if (!targets.empty())
    for (const Vec& u : ctx.model->sample(targets))
      run.target_displacement.push_back(ctx.tf.vector_to_world(u));

  const bool write = writes_steps(ctx.opt) && ctx.sc.output_every > 0;
  const std::string file = "steps/" + step_file(0, ctx.opt.mpi_ranks);
  if (write) write_step_vtu<dim>(ctx, file, &solution);
  if (write && ctx.opt.output_file) write_pvd(ctx.opt.output_file("simulation.pvd"), {{0.0, file}});
  json final_targets = json::object();
  for (std::size_t t = 0; t < run.target_displacement.size(); ++t) {
    const Vec& u = run.target_displacement[t];
    json d = json::array();
    for (int c = 0; c < dim; ++c) d.push_back(u[c]);
    final_targets[ctx.sc.targets[t].name] = {{"displacement", d}, {"norm", u.norm()}};
  }
  json report = {{"steps", 1},
                 {"material_model", finite_strain ? "neo-hookean" : "linear"},
                 {"files", write ? json::array({file}) : json::array()},
                 {"max_displacement", run.max_displacement},
                 {"max_strain", run.max_strain},
                 {"targets", final_targets},
                 {"solver",
                  {{"method", run.stats.method},
                   {"n_dofs", run.stats.n_dofs},
                   {"solves", 1},
                   {"iterations", run.stats.iterations},
                   {"residual", run.stats.residual}}},
                 // the solve's parts (SolverStats): set-up and assembly, preconditioner set-up and CG within
                 {"timing",
                  {{"solve_seconds", solve_seconds},
                   {"setup_seconds", run.stats.setup_seconds},
                   {"assemble_seconds", run.stats.assemble_seconds},
                   {"precondition_seconds", run.stats.precondition_seconds},
                   {"cg_seconds", run.stats.solve_seconds - run.stats.precondition_seconds}}}};
  if (!compared.is_null()) report["compare_linear"] = compared;
  if (finite_strain) {
    report["newton"] = newton;
    return {std::move(run), std::move(report)};  // a finite-strain solve: no small-strain warning
  }
  const std::string w = small_strain_warning(ctx.sc.where(0), "the static load case", {run.max_strain});
  if (!w.empty()) warnings.push_back(w);
  return {std::move(run), std::move(report)};
}

template StaticLoadOutcome<2> run_static_load<2>(SimulationContext<2>&, std::vector<std::string>&);
template StaticLoadOutcome<3> run_static_load<3>(SimulationContext<3>&, std::vector<std::string>&);

}  // namespace vim::pipeline

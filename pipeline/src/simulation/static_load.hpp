// Private to the simulation sources: a scenario without a needle is a static load case — the model
// under its boundary conditions alone (prescribed displacements, pressures, tractions), solved once and
// written as step 0, like the rest state of a needle run.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "simulation/simulation_context.hpp"

namespace vim::pipeline {

// Solves the loaded model once; writes steps/step_0000.vtu and simulation.pvd when the options name an
// output folder; returns the run with its entry report.json["simulation"]["static_load"], and adds the
// small-strain warning to `warnings`.
template <int dim>
struct StaticLoadOutcome {
  StaticLoadRun<dim> run;
  nlohmann::json report;
};
template <int dim>
StaticLoadOutcome<dim> run_static_load(SimulationContext<dim>& ctx, std::vector<std::string>& warnings);

}  // namespace vim::pipeline

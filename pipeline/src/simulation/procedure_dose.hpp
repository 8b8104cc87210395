// Private to the simulation sources: the dose of a procedure's seeds (docs/dose.md), planned and
// final, on a grid over the image box; D90/V100/V150 over the points of the scenario's dose region.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation/simulation_context.hpp"

namespace vim::pipeline {

// report.json["simulation"]["dose"]; writes dose_planned.mha and dose_final.mha (Gy, the input's
// world geometry) when the options name an output folder. 3D only (the parser refuses 2D). Throws
// ScenarioError when the region holds no point of the grid.
template <int dim>
nlohmann::json procedure_dose(const SimulationContext<dim>& ctx, const std::vector<NeedleRun<dim>>& needles);

}  // namespace vim::pipeline

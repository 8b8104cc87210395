// `vim-pipeline IMAGE --simulate S.yaml --fit-forces MEASURED.csv --out DIR`: the mesh is made once, the
// scenario's needle is fitted to the measured curve (force_fit.hpp), DIR gets fit.json, fitted.yaml and
// figures/force_fit.png, then the fitted scenario runs into DIR as --simulate runs it.
#pragma once

#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

// Throws InputError / ScenarioError for bad inputs (the CSV's, the scenario's), before any work where
// it can.
void run_force_fit(const RunOptions& options);

}  // namespace vim::pipeline

// Private to the run_*.cpp stages of PipelineRun (pipeline_run.hpp) and the study: message formatting
// and the options as report.json records them.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

// printf-style formatting of a progress or warning line (at most 511 characters).
std::string fmt(const char* format, ...) __attribute__((format(printf, 1, 2)));

// report.json "options": every option of the run as it applies (scenario mesh keys included;
// run_write_report.cpp).
nlohmann::json options_json(const RunOptions& options);

// Poisson ratio from which a degree-1 simulation warns about volumetric locking.
constexpr double kLockingPoisson = 0.4;

}  // namespace vim::pipeline

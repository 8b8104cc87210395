// Private to study.cpp: what became of each case of a study (CaseOutcome), its exchange between MPI
// ranks as JSON, and study.csv (one row per case).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <vim/pipeline/study/study.hpp>

namespace vim::pipeline {

struct CaseOutcome {
  std::size_t index = 0;  // in Study::cases
  std::string status;     // "done" or "failed"
  std::string message;    // why it failed
  bool resumed = false;   // done by an earlier run (its folder was complete)
  // Per needle of the case's report.json: {name, axial_force, lateral_force, targets: {name: [x, y, z]}}.
  nlohmann::json needles = nlohmann::json::array();
  // A procedure's seeds and dose (procedure_results), the study.csv columns of procedure_columns().
  nlohmann::json procedure = nlohmann::json::object();
};

// The final forces and target displacements of a case's report.json (as the report holds them).
nlohmann::json final_results(const nlohmann::json& report);
// A procedure's seed error (mean, RMS, largest over all seeds) and dose (D90, V100 planned and final)
// of a case's report.json, by study.csv column name; empty without a procedure.
nlohmann::json procedure_results(const nlohmann::json& report);

// Outcomes to and from JSON (the exchange between ranks): json(outcomes), j.get<std::vector<CaseOutcome>>().
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(CaseOutcome, index, status, message, resumed, needles, procedure)

// study.csv (written under a temporary name, then renamed): a row per case in study order: case,
// status, the varied inputs as the case's scenario reads them, per needle the final axial and lateral
// force and each target's displacement (x, y[, z]), with a procedure its seed error (seeds) and dose
// (dose:) columns, the message of a failed case.
void write_study_csv(const std::filesystem::path& path, const Study& study,
                     const std::vector<CaseOutcome>& outcomes);

}  // namespace vim::pipeline

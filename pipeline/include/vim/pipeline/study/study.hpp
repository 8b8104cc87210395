// A study (README "Studies"): one base scenario run many times with some of its values varied — a
// list of cases and/or a grid (every combination) over the needle's entry, direction and depth, the
// material's scale and Poisson ratio and the stick-slip friction limit. `vim-pipeline IMAGE --study
// study.yaml --out DIR` makes the mesh once per mesh setting, runs every case into DIR/cases/NAME/
// (the files of one --simulate run, plus case.yaml: the case's own scenario) and writes DIR/study.csv,
// a row per case. A case whose folder holds its report.json is not run again (resumable); a failed
// case is recorded in study.csv and the others go on. Under mpirun, case i runs on rank i mod N.
//
//   scenario: needle.yaml          # the base scenario, relative to this file
//   cases:                         # optional: a list of cases, each with an optional name
//     - {name: shallow, depth: 20}
//     - {name: deep, depth: 40, entry: [-30, -5, 3]}
//   grid:                          # optional: every combination of these values
//     scale: [0.5, 1.0, 2.0]
//     poisson_ratio: [0.45, 0.49]
//
// With both, every case is combined with every grid point. study.cpp runs it; study_reader.cpp reads it.
#pragma once

#include <optional>
#include <string>
#include <vector>
#include <vim/pipeline/run/run_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// The values a study may vary: the study key and the scenario key it sets.
struct StudyKey {
  const char* name;          // key in study.yaml
  const char* scenario_key;  // what it sets in the base scenario
};
const std::vector<StudyKey>& study_keys();
// A procedure's action may be varied too: `procedure[N].K` sets K of action N (from 0) of the base's
// procedure, K one of entry, direction, depth, seeds (an insert) or translate, rotate (a probe motion).
struct ActionKey {
  std::size_t index = 0;
  std::string key;
};
std::optional<ActionKey> action_key(const std::string& key);  // nullopt: not of that form
inline constexpr const char* kActionKeyPattern = "procedure[N].entry|direction|depth|seeds|translate|rotate";

struct StudyCase {
  std::string name;  // folder name under DIR/cases/
  // The varied keys of this case (study_keys() names) and their values as written in study.yaml.
  std::vector<std::pair<std::string, std::string>> values;
  Scenario scenario;  // the base scenario with the values applied, checked by the scenario parser
  // The scenario as YAML (the base's keys with the values applied): written as the case's case.yaml,
  // and what --simulate would run alone.
  std::string scenario_text;
  // Cases with the same mesh_key share one mesh: empty unless mesh.needle_refinement makes the mesh
  // follow the needle paths.
  std::string mesh_key;
};

struct Study {
  std::string source;               // the study file, as given
  std::string base_scenario;        // the base scenario's path (relative to the working directory)
  Scenario base;                    // the base scenario as read
  std::vector<std::string> varied;  // the study keys any case varies, in study_keys() order
  std::vector<StudyCase> cases;     // list cases (outer) × grid points (inner, first key slowest)
};

// Reads and checks a study for a `dim`-dimensional image: the base scenario and every case's scenario
// are parsed (and checked) before any work. Throws ScenarioError naming the file, line and key.
Study read_study(const std::string& path, int dim);
Study parse_study_text(const std::string& yaml_text, const std::string& source, int dim);

// Runs `options.study` for options.image into options.out (study.cpp). Collective under mpirun: every
// rank calls it. Returns the exit code (0: every case done; 1: an error, printed once, or a failed
// case); errors are printed as one `vim-pipeline: error:` line by one rank.
int run_study(const RunOptions& options);

// True (after printing the error on rank 0 alone) when an MPI launcher started several processes for a
// run that is neither a study nor a simulation (meshing alone, --info): nothing of it runs over ranks.
bool refused_on_many_ranks(const RunOptions& options);

}  // namespace vim::pipeline

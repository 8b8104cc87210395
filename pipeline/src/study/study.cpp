// Running a study (study.hpp). Every rank reads the study and checks the output folder (an error is
// printed once and every rank exits with 1); rank r runs the cases i with i mod N = r, grouped by mesh
// setting so that the mesh is made once per group (PipelineRun::reuse_mesh); a failed case is recorded
// and the others go on; rank 0 gathers the outcomes and writes study.csv.
#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>
#include <vim/pipeline/study/study.hpp>

#include "run/run_support.hpp"
#include "study/study_ranks.hpp"
#include "study/study_table.hpp"

namespace vim::pipeline {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

fs::path case_folder(const RunOptions& o, const StudyCase& c) { return o.out / "cases" / c.name; }

// case.yaml: the case's scenario, then (as a comment at the end, so that the scenario's line numbers
// hold) the options that shape its results. A folder whose case.yaml differs holds another case.
std::string case_file_text(const RunOptions& o, const StudyCase& c) {
  json options = options_json(o);
  for (const char* k : {"out", "overwrite", "threads", "simulate", "export"}) options.erase(k);
  return c.scenario_text + "# vim-pipeline options: " + options.dump() + "\n";
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The results of an earlier run of the case, if its folder is complete (report.json and case.yaml);
// throws InputError if the folder holds a run of another scenario or other options.
std::optional<std::pair<json, json>> earlier_results(const RunOptions& o, const Study& study,
                                                     const StudyCase& c) {
  const fs::path dir = case_folder(o, c);
  if (o.overwrite || !fs::exists(dir / "report.json") || !fs::exists(dir / "case.yaml")) return std::nullopt;
  if (read_text(dir / "case.yaml") != case_file_text(o, c))
    throw InputError((dir / "case.yaml").string() + ": this folder holds a run of case '" + c.name +
                     "' with another scenario or other options than " + study.source +
                     " and the command line now give; remove the folder to run the case again, or give "
                     "--overwrite to run every case again");
  try {
    std::ifstream in(dir / "report.json");
    const json report = json::parse(in);
    return std::make_pair(final_results(report), procedure_results(report));
  } catch (const std::exception&) {
    return std::nullopt;  // not a complete report: the case runs again
  }
}

// DIR may be new, empty, or the folder of an earlier run of a study (resumed).
void check_study_folder(const RunOptions& o) {
  const fs::path& out = o.out;
  if (!fs::exists(out)) return;
  if (!fs::is_directory(out)) throw InputError(out.string() + ": --out exists and is not a folder");
  if (fs::is_empty(out) || o.overwrite || fs::exists(out / "cases") || fs::exists(out / "study.csv")) return;
  throw InputError(out.string() +
                   ": --out is not empty and holds no study (no cases/ or study.csv); give a new or empty "
                   "folder, or the folder of an earlier run of the study to resume it");
}

std::string error_of(const std::function<void()>& work) {
  try {
    work();
    return "";
  } catch (const std::bad_alloc&) {
    return "out of memory (try a smaller image or fewer --nodes)";
  } catch (const std::exception& e) {
    const std::string m = e.what();
    return m.empty() ? "unknown error" : m;
  }
}

// Collective: true if no rank has an error; otherwise the lowest rank with one prints it.
bool all_succeeded(const StudyRanks& ranks, const std::string& error) {
  const int first = ranks.min(error.empty() ? ranks.size() : ranks.rank());
  if (first == ranks.rank()) print_error(error);
  return first == ranks.size();
}

// The cases of one rank. Cases of one mesh setting share the mesh of one meshing run (simplex
// meshers); the voxel model is built per case.
template <int dim>
class CaseRunner {
 public:
  CaseRunner(const RunOptions& o, const Study& study, OrientedImage<dim> image)
      : options_(o), study_(study), image_(std::move(image)) {}

  CaseOutcome run(std::size_t index) {
    const StudyCase& c = study_.cases[index];
    CaseOutcome outcome;
    outcome.index = index;
    const std::string error = error_of([&] {
      const json report = run_case(c);
      outcome.needles = final_results(report);
      outcome.procedure = procedure_results(report);
    });
    outcome.status = error.empty() ? "done" : "failed";
    outcome.message = error;
    if (!error.empty()) Log::warning("study", "case '" + c.name + "' failed: " + error);
    return outcome;
  }

 private:
  json run_case(const StudyCase& c) {
    const fs::path dir = case_folder(options_, c);
    fs::create_directories(dir);
    write_text_atomically(dir / "case.yaml", [&](std::ostream& s) { s << case_file_text(options_, c); });
    RunOptions o = options_;
    o.out = dir;
    o.overwrite = true;  // what an interrupted run left there
    o.simulate = (dir / "case.yaml").string();
    o.verbosity = Verbosity::quiet;  // no summary per case on stdout
    Scenario scenario = c.scenario;
    scenario.source = o.simulate;  // its line numbers are case.yaml's
    PipelineRun<dim> run(o, inputs(scenario));
    run.read_inputs();
    if (o.mesher == MesherKind::voxel)
      run.make_mesh();
    else
      run.reuse_mesh(mesh(c, scenario));
    run.build_model();
    run.simulate();
    run.write_outputs();
    run.write_report();
    return run.report();
  }

  RunInputs<dim> inputs(Scenario scenario) const {
    RunInputs<dim> in;
    in.image = image_;
    in.scenario = std::move(scenario);
    return in;
  }

  // The mesh of c's mesh setting, kept while the group's cases run: made by a run without output
  // folder on c's scenario (checked against the image as the case's own run checks it, so that a case
  // whose needle leaves the image fails alone and the next case makes the mesh). Its Poisson ratio is
  // set to 0: only the simulation reads it, and the meshing run's warnings, which reuse_mesh passes on,
  // are then about the mesh alone (not the locking warning of another case's ratio).
  const PipelineRun<dim>& mesh(const StudyCase& c, const Scenario& scenario) {
    const std::string key = options_.mesher == MesherKind::vim ? c.mesh_key : "";
    if (mesh_ && key == mesh_key_) return *mesh_;
    mesh_.reset();
    RunOptions o = options_;
    o.out.clear();
    o.verbosity = Verbosity::quiet;
    Scenario for_mesh = scenario;
    for_mesh.poisson_ratio = 0.0;
    auto run = std::make_unique<PipelineRun<dim>>(o, inputs(std::move(for_mesh)));
    run->read_inputs();
    run->make_mesh();
    mesh_ = std::move(run);
    mesh_key_ = key;
    return *mesh_;
  }

  const RunOptions& options_;
  const Study& study_;
  const OrientedImage<dim> image_;
  std::unique_ptr<PipelineRun<dim>> mesh_;
  std::string mesh_key_;
};

// This rank's cases (i mod N = rank), grouped by mesh setting in order of first appearance.
std::vector<std::size_t> cases_of_rank(const Study& study, const StudyRanks& ranks) {
  std::map<std::string, std::size_t> group;
  std::vector<std::pair<std::size_t, std::size_t>> order;  // group, case
  for (std::size_t i = static_cast<std::size_t>(ranks.rank()); i < study.cases.size();
       i += static_cast<std::size_t>(ranks.size()))
    order.emplace_back(group.emplace(study.cases[i].mesh_key, group.size()).first->second, i);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::size_t> cases;
  for (const auto& [g, i] : order) cases.push_back(i);
  return cases;
}

template <int dim>
std::vector<CaseOutcome> run_cases(const RunOptions& o, const Study& study, const StudyRanks& ranks,
                                   const ImageFile& image) {
  std::vector<CaseOutcome> outcomes;
  std::optional<CaseRunner<dim>> runner;
  const std::vector<std::size_t> mine = cases_of_rank(study, ranks);
  std::size_t count = 0;
  for (std::size_t i : mine) {
    const StudyCase& c = study.cases[i];
    ++count;
    if (const auto earlier = earlier_results(o, study, c)) {
      CaseOutcome done{i, "done", "", true, earlier->first, earlier->second};
      outcomes.push_back(std::move(done));
      Log::info("study", fmt("case '%s' (%zu of %zu on rank %d): done by an earlier run", c.name.c_str(),
                             count, mine.size(), ranks.rank()));
      continue;
    }
    if (!runner) runner.emplace(o, study, image.read<dim>());
    Log::info("study",
              fmt("case '%s' (%zu of %zu on rank %d)", c.name.c_str(), count, mine.size(), ranks.rank()));
    outcomes.push_back(runner->run(i));
  }
  return outcomes;
}

// Rank 0: every rank's outcomes in study order, study.csv, and the summary on stdout.
std::vector<CaseOutcome> merge_and_write(const RunOptions& o, const Study& study,
                                         const std::vector<std::string>& per_rank) {
  std::vector<CaseOutcome> all;
  for (const std::string& text : per_rank)
    for (CaseOutcome& c : json::parse(text).get<std::vector<CaseOutcome>>()) all.push_back(std::move(c));
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
  if (all.size() != study.cases.size()) throw std::logic_error("study: a rank lost the outcome of a case");
  fs::create_directories(o.out);
  write_study_csv(o.out / "study.csv", study, all);
  const auto failed = std::count_if(all.begin(), all.end(), [](const auto& c) { return c.status != "done"; });
  const auto resumed = std::count_if(all.begin(), all.end(), [](const auto& c) { return c.resumed; });
  if (o.verbosity != Verbosity::quiet)
    std::cout << "study " << study.source << ": " << all.size() << " cases, " << all.size() - failed
              << " done (" << resumed << " by an earlier run), " << failed << " failed; "
              << (o.out / "study.csv").string() << "\n";
  return all;
}

template <int dim>
int run_study_in(const RunOptions& given, const StudyRanks& ranks, const ImageFile& image) {
  RunOptions o = given;
  if (o.threads == 0 && ranks.size() > 1)  // the rank's share of the cores
    o.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / ranks.size());
  Study study;
  if (!all_succeeded(ranks, error_of([&] {
                       study = read_study(o.study, dim);
                       check_study_folder(o);
                       for (const StudyCase& c : study.cases)
                         earlier_results(o, study, c);  // a foreign case folder
                     })))
    return 1;
  std::vector<CaseOutcome> mine;
  const std::string run_error = error_of([&] { mine = run_cases<dim>(o, study, ranks, image); });
  const std::vector<std::string> per_rank = ranks.gather(json(mine).dump());
  std::size_t failed = 0;
  std::string error = run_error;
  if (ranks.rank() == 0 && error.empty())
    error = error_of([&] {
      for (const CaseOutcome& c : merge_and_write(o, study, per_rank)) failed += c.status != "done";
    });
  if (!all_succeeded(ranks, error)) return 1;
  if (failed > 0)
    print_error(fmt("%zu of %zu cases of %s failed (status and message in %s)", failed, study.cases.size(),
                    o.study.c_str(), (o.out / "study.csv").string().c_str()));
  return ranks.max(failed > 0 ? 1 : 0);
}

}  // namespace

bool refused_on_many_ranks(const RunOptions& options) {
  const LauncherRanks launched = launcher_ranks();
  if (!options.study.empty() || !options.simulate.empty() || launched.size == 1) return false;
  if (launched.rank == 0)
    print_error("started by mpirun on " + std::to_string(launched.size) +
                " processes: only a simulation (--simulate, its solves over the ranks) or a study (--study, "
                "case i on rank i mod N) runs on several ranks; run meshing or --info without mpirun");
  return true;
}

int run_study(const RunOptions& options) {
  std::optional<StudyRanks> ranks;
  std::optional<ImageFile> image;
  const std::string error = error_of([&] { ranks.emplace(); });
  if (!error.empty()) {
    print_error(error);
    return 1;
  }
  if (!all_succeeded(*ranks, error_of([&] { image.emplace(options.image); }))) return 1;
  return image->dimension() == 2 ? run_study_in<2>(options, *ranks, *image)
                                 : run_study_in<3>(options, *ranks, *image);
}

}  // namespace vim::pipeline

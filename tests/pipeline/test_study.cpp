// Studies through the real CLI (vim-pipeline IMAGE --study study.yaml --out DIR). Truths: each case's
// row equals the same scenario run alone with --simulate on its case.yaml (an independent run that
// makes its own mesh); with displacement-driven loading, linear elasticity gives forces proportional
// to the modulus scale and target displacements independent of it; a resumed study leaves the complete
// case folders untouched and writes the same study.csv; a failing case is recorded and the others run.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vim/pipeline/study/study.hpp>

#include "run_cli.hpp"
#include "study_inputs.hpp"

using vim::test::quote;
using vim::test::read_study_csv;
using vim::test::run_pipeline;
using vim::test::slurp;
using vim::test::study_options;
namespace fs = std::filesystem;

namespace {

void write_file(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

double number(const std::map<std::string, std::string>& row, const std::string& column) {
  return std::stod(row.at(column));
}

}  // namespace

TEST(StudyCli, EveryCaseEqualsItsScenarioRunAloneAndForcesScaleWithTheModulus) {
  vim::test::TempDir dir("study_grid");
  vim::test::write_study_inputs(dir.path);
  write_file(dir.path / "study.yaml",
             "scenario: base.yaml\n"
             "cases:\n"
             "  - {name: straight}\n"
             "  - {name: tilted, direction: [1, 0.2, 0]}\n"
             "grid:\n"
             "  scale: [10, 25]\n");
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(study_options(dir.path, "study.yaml", out));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto rows = read_study_csv(out / "study.csv");
  ASSERT_EQ(rows.size(), 4u);
  const char* names[] = {"straight-g1", "straight-g2", "tilted-g1", "tilted-g2"};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].at("case"), names[i]);
    EXPECT_EQ(rows[i].at("status"), "done") << rows[i].at("message");
    EXPECT_TRUE(fs::exists(out / "cases" / names[i] / "report.json"));
  }
  EXPECT_EQ(number(rows[1], "scale"), 25.0);
  EXPECT_NEAR(number(rows[2], "direction_y"), 0.2 / std::sqrt(1.04), 1e-15);  // normalised as the parser does

  // Linear elasticity under prescribed displacements: forces ∝ modulus, displacements independent of it.
  for (std::size_t i : {0u, 2u}) {
    for (const char* f : {"axial_force", "lateral_force"})
      EXPECT_NEAR(number(rows[i + 1], f), 2.5 * number(rows[i], f), 1e-8 * std::abs(number(rows[i + 1], f)))
          << names[i] << " " << f;
    for (const char* u : {"ahead_x", "ahead_y", "ahead_z"})
      EXPECT_NEAR(number(rows[i + 1], u), number(rows[i], u), 1e-10) << names[i] << " " << u;
  }
  EXPECT_GT(number(rows[2], "lateral_force"), 2.0 * number(rows[0], "lateral_force"));  // the tilt bends

  // A case alone: its case.yaml with --simulate, on a mesh of its own.
  const fs::path alone = dir.path / "alone";
  const auto a = run_pipeline(
      quote(dir / "in.mha") + " --nodes 100 --max-iterations 3 --export none -q --simulate " +
      quote((out / "cases" / "tilted-g2" / "case.yaml").string()) + " --out " + quote(alone.string()));
  ASSERT_EQ(a.code, 0) << a.err;
  const auto rep = nlohmann::json::parse(slurp(alone / "report.json"));
  const auto& fin = rep["simulation"]["needles"][0]["final"];
  EXPECT_NEAR(number(rows[3], "axial_force"), fin["axial_force"].get<double>(), 1e-10);
  EXPECT_NEAR(number(rows[3], "lateral_force"), fin["lateral_force"].get<double>(), 1e-10);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(number(rows[3], std::string("ahead_") + "xyz"[c]),
                fin["targets"]["ahead"]["displacement"][c].get<double>(), 1e-12);
}

TEST(StudyCli, ResumingRunsOnlyTheIncompleteCasesAndWritesTheSameTable) {
  vim::test::TempDir dir("study_resume");
  vim::test::write_study_inputs(dir.path);
  write_file(dir.path / "study.yaml", "scenario: base.yaml\ngrid:\n  depth: [1.0, 1.25, 1.5]\n");
  const fs::path out = dir.path / "out";
  ASSERT_EQ(run_pipeline(study_options(dir.path, "study.yaml", out)).code, 0);
  const std::string first = slurp(out / "study.csv");
  const auto kept = fs::last_write_time(out / "cases" / "g1" / "report.json");
  fs::remove_all(out / "cases" / "g2");                                     // never run
  fs::remove(out / "cases" / "g3" / "report.json");                         // interrupted before its report
  const auto r = run_pipeline(study_options(dir.path, "study.yaml", out));  // the same command again
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(out / "study.csv"), first);
  EXPECT_EQ(fs::last_write_time(out / "cases" / "g1" / "report.json"), kept);  // not run again
  EXPECT_TRUE(fs::exists(out / "cases" / "g2" / "report.json"));
  EXPECT_TRUE(fs::exists(out / "cases" / "g3" / "report.json"));

  // A changed study is not mixed with the folders of the old one.
  write_file(dir.path / "study.yaml", "scenario: base.yaml\ngrid:\n  depth: [1.1, 1.25, 1.5]\n");
  const auto changed = run_pipeline(study_options(dir.path, "study.yaml", out));
  EXPECT_EQ(changed.code, 1);
  EXPECT_NE(changed.err.find("g1/case.yaml: this folder holds a run of case 'g1' with another scenario"),
            std::string::npos)
      << changed.err;
  EXPECT_EQ(vim::test::count_lines(changed.err), 1) << changed.err;
  EXPECT_EQ(slurp(out / "study.csv"), first);
}

TEST(StudyCli, AFailedCaseIsRecordedAndTheOthersGoOn) {
  vim::test::TempDir dir("study_fail");
  vim::test::write_study_inputs(dir.path);
  write_file(dir.path / "study.yaml",
             "scenario: base.yaml\n"
             "cases:\n"
             "  - {name: too-deep, depth: 10.0}\n"
             "  - {name: fine, depth: 1.0}\n");
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(study_options(dir.path, "study.yaml", out));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("vim-pipeline: error: 1 of 2 cases"), std::string::npos) << r.err;
  const auto rows = read_study_csv(out / "study.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].at("status"), "failed");
  EXPECT_NE(rows[0].at("message").find("needle.depth = 10 takes the tip out of the image box"),
            std::string::npos)
      << rows[0].at("message");
  EXPECT_EQ(rows[0].at("axial_force"), "");
  EXPECT_FALSE(fs::exists(out / "cases" / "too-deep" / "report.json"));
  EXPECT_EQ(rows[1].at("status"), "done");
  EXPECT_GT(number(rows[1], "axial_force"), 0.0);  // the tissue resists the needle
}

// The README's study and examples/prostate_study.yaml are valid studies of the shipped prostate
// scenario. Truth: the case counts and names the README's rules give (list × grid, g1… per point).
TEST(StudyCli, ReadmeStudyAndExampleParse) {
  const fs::path examples = fs::path(VIM_SOURCE_DIR) / "examples";
  const auto example = vim::pipeline::read_study((examples / "prostate_study.yaml").string(), 3);
  ASSERT_EQ(example.cases.size(), 6u);
  EXPECT_EQ(example.cases[0].name, "lesion-g1");
  EXPECT_EQ(example.cases[5].name, "above-g3");
  EXPECT_EQ(example.cases[5].scenario.needles[0].depth, 30.0);
  EXPECT_EQ(example.cases[5].scenario.scale, 2.0);
  EXPECT_NE(example.cases[0].mesh_key, example.cases[3].mesh_key);  // needle_refinement: a mesh per path
  EXPECT_EQ(example.cases[0].mesh_key, example.cases[2].mesh_key);

  const std::string readme = slurp(fs::path(VIM_SOURCE_DIR) / "README.md");
  const auto b = readme.find("```yaml\n", readme.find("## Studies (`--study`)"));
  ASSERT_NE(b, std::string::npos);
  const auto e = readme.find("```", b + 8);
  // Read as if it were a file in examples/, where its base scenario is.
  const auto study = vim::pipeline::parse_study_text(readme.substr(b + 8, e - b - 8),
                                                     (examples / "readme_study.yaml").string(), 3);
  EXPECT_EQ(study.cases.size(), 12u);
  EXPECT_EQ(study.cases[1].name, "lesion-g2");
  EXPECT_EQ(study.cases[1].scenario.poisson_ratio, 0.49);
  EXPECT_EQ((std::vector<std::string>{"entry", "depth", "scale", "poisson_ratio"}), study.varied);
}

// A procedure as the base: study.csv gets the seed error and the dose of each case's report.json; a
// stuck needle moves the tissue kinematically, so with a fixed face and no loads neither depends on the
// modulus scale (linear elasticity: the displacements of prescribed displacements are independent of it).
TEST(StudyCli, ProcedureColumnsAreTheCaseReportsSeedErrorAndDose) {
  vim::test::TempDir dir("study_procedure");
  vim::test::write_study_inputs(dir.path);
  write_file(dir.path / "plan.yaml",
             "units: {length: mm, modulus: kPa}\n"
             "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
             "boundary_conditions: [{type: fixed, region: {box_face: x_max}}]\n"
             "procedure:\n"
             "  - insert: {name: a, entry: [0, 1.4, 1.6], direction: [1, 0, 0], depth: 1.5, steps: 3,\n"
             "             diameter: 0.2, friction: {model: stick}, seeds: [0.5, 1.0, 1.5]}\n"
             "  - withdraw: {needle: a, steps: 3}\n"
             "dose: {seed_model: amersham_6711, air_kerma_strength: 0.5, grid: 0.25,\n"
             "       region: {sphere: {center: [1.5, 1.5, 1.5], radius: 1}}}\n"
             "output: {every: 0}\n");
  write_file(dir.path / "study.yaml", "scenario: plan.yaml\ngrid:\n  scale: [10, 25]\n");
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(study_options(dir.path, "study.yaml", out));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto rows = read_study_csv(out / "study.csv");
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& row : rows) {
    ASSERT_EQ(row.at("status"), "done") << row.at("message");
    const auto report = nlohmann::json::parse(slurp(out / "cases" / row.at("case") / "report.json"));
    const auto& sim = report["simulation"];
    EXPECT_EQ(number(row, "seed_error_max"), sim["seeds"]["all"]["max_error"].get<double>());
    EXPECT_EQ(number(row, "seed_error_rms"), sim["seeds"]["all"]["rms_error"].get<double>());
    EXPECT_EQ(number(row, "d90_final"), sim["dose"]["final"]["d90_gy"].get<double>());
    EXPECT_EQ(number(row, "v100_planned"), sim["dose"]["planned"]["v100_percent"].get<double>());
  }
  EXPECT_GT(number(rows[0], "seed_error_max"), 1e-4);
  EXPECT_NEAR(number(rows[1], "seed_error_max"), number(rows[0], "seed_error_max"),
              1e-8 * number(rows[0], "seed_error_max"));
  EXPECT_NEAR(number(rows[1], "d90_final"), number(rows[0], "d90_final"),
              1e-8 * number(rows[0], "d90_final"));
}

// Study keys on a procedure's actions: `procedure[N].K` sets K of action N in each case's scenario (the
// parser's NeedleSpec carries it), study.csv has its columns as written, and each case's seeds.csv has the
// seeds at the planned positions entry + depth·direction of the case's values.
TEST(StudyCli, ActionKeysReachTheProcedureAndItsColumns) {
  vim::test::TempDir dir("study_actions");
  vim::test::write_study_inputs(dir.path);
  write_file(dir.path / "plan.yaml",
             "units: {length: mm, modulus: kPa}\n"
             "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
             "boundary_conditions: [{type: fixed, region: {box_face: x_max}}]\n"
             "procedure:\n"
             "  - insert: {name: a, entry: [0, 1.4, 1.6], direction: [1, 0, 0], depth: 1.5, steps: 3,\n"
             "             diameter: 0.2, friction: {model: stick}, seeds: [0.5, 1.0, 1.5]}\n"
             "  - withdraw: {needle: a, steps: 3}\n"
             "output: {every: 0}\n");
  write_file(dir.path / "study.yaml",
             "scenario: plan.yaml\n"
             "cases:\n  - {name: here}\n  - {name: moved, \"procedure[0].entry\": [0, 1.6, 1.4]}\n"
             "grid:\n  procedure[0].seeds: [[0.5, 1.0, 1.5], [0.75, 1.25]]\n");
  const auto study = vim::pipeline::read_study((dir.path / "study.yaml").string(), 3);
  ASSERT_EQ(study.cases.size(), 4u);
  EXPECT_EQ((std::vector<std::string>{"procedure[0].seeds", "procedure[0].entry"}),
            study.varied);  // as first varied
  EXPECT_EQ(study.cases[1].name, "here-g2");
  EXPECT_EQ(study.cases[1].scenario.needles.at(0).seeds, (std::vector<double>{0.75, 1.25}));
  EXPECT_EQ(study.cases[3].scenario.needles.at(0).entry, (std::vector<double>{0, 1.6, 1.4}));
  EXPECT_EQ(study.cases[0].scenario.needles.at(0).entry, (std::vector<double>{0, 1.4, 1.6}));
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(study_options(dir.path, "study.yaml", out));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto rows = read_study_csv(out / "study.csv");
  ASSERT_EQ(rows.size(), 4u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    ASSERT_EQ(row.at("status"), "done") << row.at("message");
    const auto& needle = study.cases[i].scenario.needles.at(0);
    EXPECT_EQ(number(row, "procedure[0].entry_y"), needle.entry[1]);
    EXPECT_EQ(number(row, "procedure[0].entry_z"), needle.entry[2]);
    EXPECT_EQ(row.at("procedure[0].seeds"), i % 2 ? "0.75 1.25" : "0.5 1.0 1.5");
    const auto report = nlohmann::json::parse(slurp(out / "cases" / row.at("case") / "report.json"));
    EXPECT_EQ(number(row, "seed_error_max"), report["simulation"]["seeds"]["all"]["max_error"].get<double>());
    EXPECT_EQ(report["simulation"]["seeds"]["all"]["count"].get<std::size_t>(), needle.seeds.size());
    // seeds.csv: the planned positions of the case's entry and depths.
    std::ifstream seeds(out / "cases" / row.at("case") / "seeds.csv");
    std::string line;
    std::getline(seeds, line);
    const std::string header = line;
    std::size_t n = 0;
    while (std::getline(seeds, line)) {
      std::vector<std::string> cells;
      std::stringstream cs(line);
      for (std::string c; std::getline(cs, c, ',');) cells.push_back(c);
      std::stringstream hs(header);
      std::map<std::string, std::string> cell;
      std::size_t k = 0;
      for (std::string h; std::getline(hs, h, ',') && k < cells.size(); ++k) cell[h] = cells[k];
      ASSERT_LT(n, needle.seeds.size());
      EXPECT_NEAR(std::stod(cell.at("planned_x")), needle.entry[0] + needle.seeds[n], 1e-10) << line;
      EXPECT_NEAR(std::stod(cell.at("planned_y")), needle.entry[1], 1e-10) << line;
      EXPECT_NEAR(std::stod(cell.at("planned_z")), needle.entry[2], 1e-10) << line;
      ++n;
    }
    EXPECT_EQ(n, needle.seeds.size()) << header;
  }
}

TEST(StudyCli, BadActionKeysNameTheFileLineAndKey) {
  vim::test::TempDir dir("study_action_errors");
  write_file(dir.path / "plan.yaml",
             "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: x_max}}]\n"
             "procedure:\n"
             "  - insert: {name: a, entry: [0, 1.4, 1.6], direction: [1, 0, 0], depth: 1.5, steps: 3,\n"
             "             diameter: 0.2, friction: {model: stick}, seeds: [0.5, 1.0, 1.5]}\n"
             "  - withdraw: {needle: a, steps: 3}\n");
  const auto error = [&](const std::string& study) {
    try {
      vim::pipeline::parse_study_text("scenario: plan.yaml\n" + study, (dir.path / "s.yaml").string(), 3);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string e = error("grid:\n  procedure[2].depth: [1]\n");
  EXPECT_NE(e.find("s.yaml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[2].depth varies an action of a procedure, but"), std::string::npos) << e;
  EXPECT_NE(e.find("has 2 actions (numbered from 0)"), std::string::npos) << e;
  e = error("grid:\n  procedure[1].depth: [1]\n");
  EXPECT_NE(e.find("procedure[1] of"), std::string::npos) << e;
  EXPECT_NE(e.find("is a 'withdraw' action, which has no depth to vary"), std::string::npos) << e;
  e = error("cases:\n  - procedure[0].seeds: 5\n");
  EXPECT_NE(e.find("cases[0].procedure[0].seeds must be a non-empty list of depths, got '5'"),
            std::string::npos)
      << e;
  e = error("cases:\n  - procedure[0].length: 5\n");
  EXPECT_NE(e.find("unknown key 'cases[0].procedure[0].length'"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[N].entry|direction|depth|seeds|translate|rotate"), std::string::npos) << e;
  e = error("grid:\n  procedure[0].seeds: [[0.5, 2.0]]\n");  // beyond the depth: the scenario parser
  EXPECT_NE(e.find("s.yaml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("procedure[0].insert.seeds[1] = 2 must be a depth in (0, 1.5]"), std::string::npos) << e;
}

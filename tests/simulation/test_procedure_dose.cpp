// The dose of a procedure's seeds (`dose:`, docs/dose.md) through the simulation: D90/V100/V150 of the
// region for the planned and the final seed positions. Truth: the same metrics recomputed here by brute
// force on the grid the scenario describes (cell centres of spacing h over the model's box, the points
// inside the sphere), from the seeds' positions in the run and the TG-43 dose of each seed
// (Tg43Dose checks that dose against the published tables).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>
#include <vim/pipeline/dose/dose_volume.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

const std::string kPlan =
    "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
    "procedure:\n"
    "  - insert: {name: a, entry: [0.3, 0.2, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1,\n"
    "             friction: {model: stick-slip, max_shear_per_length: 0.5}, seeds: [4, 8, 12]}\n"
    "dose: {seed_model: amersham_6711, air_kerma_strength: 0.5, prescription: 145, grid: 1,\n"
    "       region: {sphere: {center: [0.3, 0.2, 8], radius: 5}}}\n";

// D90, V100, V150 of the sphere's grid points for seeds at `seeds`, by sorting here.
std::vector<double> brute_force(const std::vector<dose::Point>& seeds) {
  const dose::SeedModel& m = dose::seed_model("amersham_6711");
  std::vector<double> d;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j)
      for (int k = 0; k < 24; ++k) {
        const dose::Point p{{-6 + i + 0.5, -6 + j + 0.5, k + 0.5}};
        if (std::hypot(p[0] - 0.3, p[1] - 0.2, p[2] - 8) <= 5)
          d.push_back(dose::seeds_dose_gy(m, 0.5, seeds, p));
      }
  std::sort(d.begin(), d.end(), std::greater<>());
  const auto share = [&](double level) {
    return 100.0 *
           static_cast<double>(std::count_if(d.begin(), d.end(), [&](double x) { return x >= level; })) /
           static_cast<double>(d.size());
  };
  return {d[static_cast<std::size_t>(std::ceil(0.9 * static_cast<double>(d.size()))) - 1], share(145),
          share(217.5), static_cast<double>(d.size())};
}

}  // namespace

TEST(ProcedureDose, PlannedAndFinalMetricsMatchABruteForceRecount) {
  const Scenario sc = parse_scenario_text(kPlan, 3, "plan.yaml");
  ASSERT_TRUE(sc.dose.has_value());
  const SimulationResult<3> res = run_simulation<3>(axis_block(), sc, quiet());
  const auto& seeds = res.needles.at(0).seeds;
  ASSERT_EQ(seeds.size(), 3u);
  std::vector<dose::Point> planned, final_positions;
  for (const auto& s : seeds) {
    planned.push_back({{s.planned[0], s.planned[1], s.planned[2]}});
    const V3 f = s.final_position();
    final_positions.push_back({{f[0], f[1], f[2]}});
  }
  const nlohmann::json& rep = res.report.at("dose");
  for (const auto& [key, positions] : {std::pair{"planned", planned}, std::pair{"final", final_positions}}) {
    const std::vector<double> truth = brute_force(positions);
    EXPECT_EQ(rep["region_points"].get<double>(), truth[3]);
    EXPECT_NEAR(rep[key]["d90_gy"].get<double>(), truth[0], 1e-9 * truth[0]) << key;
    EXPECT_NEAR(rep[key]["v100_percent"].get<double>(), truth[1], 1e-9) << key;
    EXPECT_NEAR(rep[key]["v150_percent"].get<double>(), truth[2], 1e-9) << key;
  }
  // The seeds moved with the tissue, so the outcome's dose differs from the plan's.
  EXPECT_GT(std::abs(rep["final"]["d90_gy"].get<double>() - rep["planned"]["d90_gy"].get<double>()), 1e-6);
}

TEST(ProcedureDose, BadDoseKeysNameTheFileLineAndKey) {
  const auto error = [](const std::string& text) -> std::string {
    try {
      parse_scenario_text(text, 3, "plan.yaml");
    } catch (const ScenarioError& e) {
      return e.what();
    }
    return "no error";
  };
  std::string bad = kPlan;
  bad.replace(bad.find("amersham_6711"), 13, "best_2301");
  std::string e = error(bad);
  EXPECT_NE(e.find("plan.yaml:6: dose.seed_model: unknown seed model 'best_2301' (known: amersham_6711)"),
            std::string::npos)
      << e;
  bad = kPlan;
  bad.replace(bad.find("grid: 1"), 7, "grid: 0");
  e = error(bad);
  EXPECT_NE(e.find("dose.grid must be > 0"), std::string::npos) << e;
  const std::string no_procedure =
      "material: {}\nboundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
      "needle: {entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, friction: {model: "
      "stick}}\n" +
      kPlan.substr(kPlan.find("dose:"));
  e = error(no_procedure);
  EXPECT_NE(e.find("plan.yaml:4: dose needs a 'procedure'"), std::string::npos) << e;
}

// The calibration of a needle to a measured insertion (force_fit.hpp): forces simulated with hidden
// values are fitted from other starting values and the hidden values come back (within 1% without
// noise; within 3 reported standard errors with 2% noise); the CSV reader and the fitted scenario.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/fit/force_fit.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

// A small block [-4,4]² × [0,16] (5×5×9 nodes), soft above z = 6 and stiffer below; a needle along the
// axis with its own cutting force and friction limit and a deeper tissue with its own limit.
MeshModel<3> small_block() {
  return block(V3(-4, -4, 0), V3(4, 4, 16), {{5, 5, 9}},
               [](const V3& x) { return x[2] > 6.0 ? 20.0 : 10.0; });
}

std::string scenario_text(double fc, double q, double q_deep) {
  return yaml("{entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 12, diameter: 1, cutting_force: " +
              std::to_string(fc) +
              ", friction: {model: stick-slip, max_shear_per_length: " + std::to_string(q) +
              "}, tissues: [{region: {box: {min: [-5, -5, 6], max: [5, 5, 17]}}, max_shear_per_length: " +
              std::to_string(q_deep) + "}]}");
}

ForceCurve simulate(const MeshModel<3>& model, const Scenario& s) {
  SimulationOptions o = quiet();
  o.step_fields = false;
  const auto r = run_simulation<3>(model, s, o);
  return {r.needles[0].depth, r.needles[0].axial_force};
}

// The hidden curve at its step depths (step 0 left out), times 1 + noise_i.
MeasuredCurve measured_curve(const MeshModel<3>& model, double noise) {
  const ForceCurve truth = simulate(model, parse_scenario_text(scenario_text(0.8, 0.15, 0.5), 3));
  std::mt19937 gen(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MeasuredCurve m;
  m.source = "measured.csv";
  for (std::size_t k = 1; k < truth.depth.size(); ++k) {
    m.depth.push_back(truth.depth[k]);
    m.force.push_back(truth.force[k] * (1.0 + noise * std::sqrt(3.0) * u(gen)));  // std = noise
    m.line.push_back(static_cast<int>(k) + 1);
  }
  return m;
}

const double kHidden[3] = {0.8, 0.15, 0.5};  // needle cutting force, needle limit, deep tissue limit

}  // namespace

TEST(ForceFit, RecoversHiddenCuttingForceAndFrictionLimitsWithoutNoise) {
  const MeshModel<3> model = small_block();
  const MeasuredCurve measured = measured_curve(model, 0.0);
  const Scenario start = parse_scenario_text(scenario_text(1.5, 0.3, 0.25), 3);
  const FitResult fit = fit_forces(start, measured, [&](const Scenario& s) { return simulate(model, s); });
  ASSERT_EQ(fit.parameters.size(), 3u);
  EXPECT_EQ(fit.parameters[0].name, "needle.cutting_force");
  EXPECT_EQ(fit.parameters[1].name, "needle.friction.max_shear_per_length");
  EXPECT_EQ(fit.parameters[2].name, "needle.tissues[0].max_shear_per_length");
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(fit.parameters[k].value, kHidden[k], 0.01 * kHidden[k]) << fit.parameters[k].name;
  EXPECT_LT(fit.rms_residual, 1e-3 * measured.force.back());
  EXPECT_GT(fit.iterations, 0);
  // The fitted scenario runs as it is and gives the fitted curve.
  const Scenario fitted = with_parameters(start, fit.parameters);
  const ForceCurve again = simulate(model, parse_scenario_text(fitted.text, 3));
  for (std::size_t i = 0; i < measured.depth.size(); ++i)
    EXPECT_NEAR(interpolate(again, measured.depth[i]), fit.fitted_force[i],
                1e-9 + 1e-9 * std::abs(fit.fitted_force[i]));
}

TEST(ForceFit, WithTwoPercentNoiseTheHiddenValuesLieWithinThreeStandardErrors) {
  const MeshModel<3> model = small_block();
  const MeasuredCurve measured = measured_curve(model, 0.02);
  const Scenario start = parse_scenario_text(scenario_text(1.5, 0.3, 0.25), 3);
  const FitResult fit = fit_forces(start, measured, [&](const Scenario& s) { return simulate(model, s); });
  ASSERT_EQ(fit.parameters.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    const FitParameter& p = fit.parameters[k];
    EXPECT_GT(p.standard_error, 0.0) << p.name;
    EXPECT_LT(p.standard_error, 0.5 * kHidden[k]) << p.name;
    EXPECT_LE(std::abs(p.value - kHidden[k]), 3.0 * p.standard_error) << p.name << " = " << p.value;
  }
  // σ from the residuals: about the noise's size.
  EXPECT_GT(fit.rms_residual, 0.0);
}

// fit: false keeps a value fixed; nothing left to fit is an error naming the scenario line.
TEST(ForceFit, FitFalseKeepsAValueAndNothingToFitIsAnError) {
  std::string text = scenario_text(1.5, 0.3, 0.25);
  text.insert(text.find("tissues:"), "fit: false, ");
  const auto p = fit_parameters(parse_scenario_text(text, 3, "s.yaml"));
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].name, "needle.tissues[0].max_shear_per_length");
  text.insert(text.find("max_shear_per_length: 0.25"), "fit: false, ");
  try {
    fit_parameters(parse_scenario_text(text, 3, "s.yaml"));
    FAIL() << "nothing to fit accepted";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("s.yaml:3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nothing to fit"), std::string::npos) << e.what();
  }
}

TEST(ForceFit, MeasuredCsvIsReadByColumnNameAndBadRowsNameTheLine) {
  const MeasuredCurve m = parse_measured_forces("time,force,depth\n0.1, 2.5, 1\n0.2,3.5,2.5\n", "m.csv");
  ASSERT_EQ(m.depth.size(), 2u);
  EXPECT_DOUBLE_EQ(m.depth[1], 2.5);
  EXPECT_DOUBLE_EQ(m.force[1], 3.5);
  EXPECT_EQ(m.line[1], 3);
  const auto error = [](const std::string& text) {
    try {
      parse_measured_forces(text, "m.csv");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error("depth,f\n1,2\n").find("m.csv:1:"), std::string::npos);
  EXPECT_NE(error("depth,force\n1,2\n1,3\n").find("m.csv:3: column 'depth' must increase"),
            std::string::npos);
  EXPECT_NE(error("depth,force\n1,2\n2,abc\n").find("m.csv:3: column 'force' must be a number"),
            std::string::npos);
}

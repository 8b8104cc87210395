// Calibration of a scenario's needle to a measured insertion (--fit-forces, docs/needle-model.md "The
// fit"): the cutting forces and stick-slip limits of the needle and of its needle.tissues entries are
// fitted by least squares (Ceres Solver, Levenberg–Marquardt with numeric differences: each residual
// evaluation is a whole simulation) to a measured axial force–depth curve.
#pragma once

#include <functional>
#include <string>
#include <vector>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// A measured force–depth curve (CSV with a header naming at least `depth` and `force`; other columns are
// ignored), in the scenario's units.
struct MeasuredCurve {
  std::string source;  // the CSV file (messages)
  std::vector<double> depth, force;
  std::vector<int> line;  // the CSV line of each row (1-based)
};

// Reads a measured curve; throws InputError naming the file, the line and the column for a missing
// column, a non-numeric cell or a depth that does not increase.
MeasuredCurve read_measured_forces(const std::string& path);
MeasuredCurve parse_measured_forces(const std::string& text, const std::string& source);

// One fitted value: the needle's own (tissue −1) or a needle.tissues entry's, of the scenario's needle.
struct FitParameter {
  enum class Kind { cutting_force, max_shear_per_length } kind = Kind::cutting_force;
  int tissue = -1;
  std::string name;  // e.g. "needle.cutting_force", "needle.tissues[1].max_shear_per_length"
  double start = 0.0, value = 0.0, standard_error = 0.0;
};

// The values --fit-forces adjusts: every positive cutting_force and max_shear_per_length of the needle
// (unless needle.fit is false) and of each needle.tissues entry (unless its fit is false); a value of 0
// (no cutting, or not given) stays as it is. Throws ScenarioError naming the file and line when the
// scenario has not exactly one needle or nothing to fit.
std::vector<FitParameter> fit_parameters(const Scenario& scenario);
// The scenario with those values (its text too: a YAML that --simulate runs as it is).
Scenario with_parameters(const Scenario& scenario, const std::vector<FitParameter>& parameters);

// A simulated axial force against depth (step 0 at depth 0 first).
struct ForceCurve {
  std::vector<double> depth, force;
};
// Linear interpolation of a curve at `depth` (clamped to its ends).
double interpolate(const ForceCurve& curve, double depth);

struct FitOptions {
  int max_iterations = 50;
  double relative_step = 1e-4;  // numeric differences: the step relative to each value
};

struct FitResult {
  std::vector<FitParameter> parameters;  // value and standard error at the solution
  std::vector<double> fitted_force;      // the fitted curve at the measured depths
  double rms_residual = 0.0;
  int iterations = 0;
  int simulations = 0;
  bool converged = false;
  std::string termination;  // Ceres' message
};

// Fits fit_parameters(scenario) to `measured`: residual i = the simulated axial force at the measured
// depth i (interpolated between steps) − the measured force. Each value is fitted as a multiple of its
// starting value, bounded positive; the standard errors are sqrt(diag(σ²(JᵀJ)⁻¹)), σ² = RSS/(n − p), at
// the solution. simulate(s) runs scenario s and returns its needle's curve.
FitResult fit_forces(const Scenario& scenario, const MeasuredCurve& measured,
                     const std::function<ForceCurve(const Scenario&)>& simulate,
                     const FitOptions& options = {});

}  // namespace vim::pipeline

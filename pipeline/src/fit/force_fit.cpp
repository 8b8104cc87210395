// The least-squares fit of a needle's parameters to a measured force–depth curve (force_fit.hpp), with
// Ceres Solver: Levenberg–Marquardt on x_k = value_k / start_k (bounded positive), numeric differences
// (each residual evaluation is one simulation), the covariance (JᵀJ)⁻¹ at the solution.
#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/fit/force_fit.hpp>

namespace vim::pipeline {

double interpolate(const ForceCurve& c, double depth) {
  if (c.depth.empty()) return 0.0;
  if (depth <= c.depth.front()) return c.force.front();
  if (depth >= c.depth.back()) return c.force.back();
  const std::size_t k =
      static_cast<std::size_t>(std::upper_bound(c.depth.begin(), c.depth.end(), depth) - c.depth.begin());
  const double t = (depth - c.depth[k - 1]) / (c.depth[k] - c.depth[k - 1]);
  return (1.0 - t) * c.force[k - 1] + t * c.force[k];
}

namespace {

// The residuals of one set of scaled values x: the simulated curve at the measured depths − measured.
struct CurveResidual {
  const Scenario* scenario;
  const MeasuredCurve* measured;
  const std::function<ForceCurve(const Scenario&)>* simulate;
  std::vector<FitParameter>* parameters;
  int* simulations;

  std::vector<double> fitted(const double* x) const {
    std::vector<FitParameter> p = *parameters;
    for (std::size_t k = 0; k < p.size(); ++k) p[k].value = p[k].start * x[k];
    const ForceCurve curve = (*simulate)(with_parameters(*scenario, p));
    ++*simulations;
    std::vector<double> f(measured->depth.size());
    for (std::size_t i = 0; i < f.size(); ++i) f[i] = interpolate(curve, measured->depth[i]);
    return f;
  }
  bool operator()(double const* const* x, double* residual) const {
    const std::vector<double> f = fitted(x[0]);
    for (std::size_t i = 0; i < f.size(); ++i) residual[i] = f[i] - measured->force[i];
    return true;
  }
};

void check_depths(const Scenario& s, const MeasuredCurve& m) {
  const double depth = s.needles.front().depth;
  for (std::size_t i = 0; i < m.depth.size(); ++i)
    if (m.depth[i] < 0.0 || m.depth[i] > depth * (1.0 + 1e-12))
      throw InputError(m.source + ":" + std::to_string(m.line[i]) + ": depth " + std::to_string(m.depth[i]) +
                       " lies outside the needle's travel [0, " + std::to_string(depth) + "] of " + s.source);
}

}  // namespace

FitResult fit_forces(const Scenario& scenario, const MeasuredCurve& measured,
                     const std::function<ForceCurve(const Scenario&)>& simulate, const FitOptions& options) {
  FitResult result;
  result.parameters = fit_parameters(scenario);
  check_depths(scenario, measured);
  const int p = static_cast<int>(result.parameters.size());
  const int n = static_cast<int>(measured.depth.size());
  if (n <= p)
    throw InputError(measured.source + ": " + std::to_string(n) + " measured rows cannot fit " +
                     std::to_string(p) + " values; give more rows than fitted values");
  std::vector<double> x(static_cast<std::size_t>(p), 1.0);
  CurveResidual residual{&scenario, &measured, &simulate, &result.parameters, &result.simulations};
  ceres::NumericDiffOptions diff;
  diff.relative_step_size = options.relative_step;
  auto* cost = new ceres::DynamicNumericDiffCostFunction<CurveResidual, ceres::CENTRAL>(
      new CurveResidual(residual), ceres::TAKE_OWNERSHIP, diff);
  cost->AddParameterBlock(p);
  cost->SetNumResiduals(n);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, x.data());
  for (int k = 0; k < p; ++k) problem.SetParameterLowerBound(x.data(), k, 1e-6);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.gradient_tolerance = 1e-14;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  result.iterations = static_cast<int>(summary.num_successful_steps + summary.num_unsuccessful_steps);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  for (int k = 0; k < p; ++k) result.parameters[k].value = result.parameters[k].start * x[k];
  result.fitted_force = residual.fitted(x.data());
  double rss = 0.0;
  for (int i = 0; i < n; ++i) rss += std::pow(result.fitted_force[i] - measured.force[i], 2);
  result.rms_residual = std::sqrt(rss / n);
  // σ²(JᵀJ)⁻¹ in x; a value's standard error is start × that of its x.
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {{x.data(), x.data()}};
  std::vector<double> c(static_cast<std::size_t>(p * p), 0.0);
  const double sigma2 = rss / (n - p);
  if (covariance.Compute(blocks, &problem) && covariance.GetCovarianceBlock(x.data(), x.data(), c.data()))
    for (int k = 0; k < p; ++k)
      result.parameters[k].standard_error = result.parameters[k].start * std::sqrt(sigma2 * c[k * p + k]);
  else
    for (auto& q : result.parameters) q.standard_error = std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace vim::pipeline

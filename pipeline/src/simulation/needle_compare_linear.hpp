// Private to the simulation sources: --compare-linear for a needle (report.json
// simulation.compare_linear): the same needle run on the linear and on the neo-Hookean model, per step
// the relative difference |linear − neo-Hookean| / |neo-Hookean| of each target's displacement vector
// and of the axial force; null where the neo-Hookean value is below 1e-6 of its largest over the steps
// (the needle has not reached the tissue yet, a target that does not move).
#pragma once

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <vim/pipeline/simulation/simulation.hpp>

namespace vim::pipeline {

// One quantity over the steps: both models' values (vectors or numbers), the relative difference per
// step, at the last step, and the largest with its step.
template <class Value, class Norm, class ToJson>
nlohmann::json compared_series(const std::vector<Value>& lin, const std::vector<Value>& nh, Norm norm,
                               ToJson to_json) {
  const std::size_t n = std::min(lin.size(), nh.size());
  double scale = 0.0;
  for (std::size_t k = 0; k < n; ++k) scale = std::max(scale, norm(nh[k]));
  nlohmann::json per_step = nlohmann::json::array(), lj = nlohmann::json::array(),
                 nj = nlohmann::json::array();
  nlohmann::json largest = nullptr, largest_step = nullptr;
  for (std::size_t k = 0; k < n; ++k) {
    lj.push_back(to_json(lin[k]));
    nj.push_back(to_json(nh[k]));
    const double d = norm(nh[k]);
    if (!(d > 1e-6 * scale)) {
      per_step.push_back(nullptr);
      continue;
    }
    const double rel = norm(lin[k] - nh[k]) / d;
    per_step.push_back(rel);
    if (largest.is_null() || rel > largest.template get<double>()) largest = rel, largest_step = k;
  }
  return {{"linear", n ? lj.back() : nlohmann::json(nullptr)},
          {"neo-hookean", n ? nj.back() : nlohmann::json(nullptr)},
          {"relative_difference", n ? per_step.back() : nlohmann::json(nullptr)},
          {"largest_relative_difference", largest},
          {"largest_step", largest_step},
          {"per_step", {{"linear", lj}, {"neo-hookean", nj}, {"relative_difference", per_step}}}};
}

// The report of one needle run on both models (lin: the linear run, nh: the neo-Hookean run).
template <int dim>
nlohmann::json compare_needle_runs(const NeedleRun<dim>& lin, const NeedleRun<dim>& nh,
                                   const std::vector<std::string>& target_names) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  const auto vec_json = [](const Vec& v) {
    nlohmann::json a = nlohmann::json::array();
    for (int c = 0; c < dim; ++c) a.push_back(v[c]);
    return a;
  };
  nlohmann::json targets = nlohmann::json::object();
  for (std::size_t t = 0; t < target_names.size(); ++t) {
    std::vector<Vec> l, n;
    for (const auto& step : lin.target_displacement) l.push_back(step[t]);
    for (const auto& step : nh.target_displacement) n.push_back(step[t]);
    targets[target_names[t]] = compared_series(
        l, n, [](const Vec& v) { return v.norm(); }, vec_json);
  }
  const auto num = [](double v) { return nlohmann::json(v); };
  return {{"name", nh.name},
          {"targets", targets},
          {"axial_force", compared_series(
                              lin.axial_force, nh.axial_force, [](double v) { return std::abs(v); }, num)},
          {"max_displacement",
           compared_series(
               std::vector<double>{lin.max_displacement}, std::vector<double>{nh.max_displacement},
               [](double v) { return std::abs(v); }, num)}};
}

// report.json simulation.compare_linear of the needles' comparisons: the first needle's at the top (the
// keys of a static load case's: targets, reactions — none —, max_displacement; and axial_force), every
// needle's in `needles`.
inline nlohmann::json compare_linear_needles(const nlohmann::json& compared) {
  return {{"definition", "|linear - neo-hookean| / |neo-hookean|"},
          {"targets", compared.front()["targets"]},
          {"axial_force", compared.front()["axial_force"]},
          {"max_displacement", compared.front()["max_displacement"]},
          {"reactions", nlohmann::json::array()},
          {"needles", compared}};
}

}  // namespace vim::pipeline

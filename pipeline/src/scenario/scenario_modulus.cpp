// The scenario's element moduli (scenario.hpp): the image checked against the material's keys, and
// Eq. 15's means with the scenario's scale and clamp.
#include <cmath>
#include <limits>
#include <string>
#include <vim/fem/material.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

template <int dim>
void check_modulus_image(const Scenario& s, const Image<dim>& image) {
  if (!s.modulus_from_image || s.clamp) return;
  std::size_t bad = 0;
  double lo = std::numeric_limits<double>::infinity();
  for (float v : image.data) {
    const double e = static_cast<double>(v) * s.scale;
    if (!(e > 0.0)) {
      ++bad;
      if (e < lo || std::isnan(e)) lo = e;
    }
  }
  if (bad)
    throw ScenarioError(s.where(0) + "material.youngs_modulus: image has " + std::to_string(bad) +
                        " voxels with a modulus that is negative, zero or NaN (e.g. " + number_text(lo) +
                        "); add material.clamp: [min, max] with min > 0 to use it");
}

// Eq. 15 is fem::element_modulus (a constant modulus: the same value for every element, scale 1); its
// message, without the function's name, follows the scenario's file and key.
std::vector<double> scenario_modulus(const Scenario& s, const std::vector<double>& mean) {
  try {
    if (s.modulus_from_image) return fem::element_modulus(mean, s.scale, s.clamp);
    return fem::element_modulus(std::vector<double>(mean.size(), s.youngs_modulus), 1.0, s.clamp);
  } catch (const std::invalid_argument& e) {
    std::string what = e.what();
    const std::string prefix = "element_modulus: ";
    if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
    throw ScenarioError(s.where(0) + "material.youngs_modulus: " + what + " (material.clamp)");
  }
}

template void check_modulus_image<2>(const Scenario&, const Image<2>&);
template void check_modulus_image<3>(const Scenario&, const Image<3>&);

}  // namespace vim::pipeline

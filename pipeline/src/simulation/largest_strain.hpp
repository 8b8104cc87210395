// Private to the simulation sources: the largest strain in the model, reported per step, and the
// warning for the first step at which it leaves the range of small-strain (linear) elasticity.
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace vim::pipeline {

// Linear elasticity assumes small strains; beyond about 10% its displacements and forces are no longer
// those of the tissue (the geometry change and the material's non-linearity are then not negligible).
inline constexpr double kSmallStrainLimit = 0.10;

// The largest principal strain magnitude over the cells: max over cells of the largest |eigenvalue| of
// the symmetric strain tensor. In 2D (plane strain) the third principal strain is ε_zz = 0, never the
// largest magnitude.
template <int dim>
double largest_principal_strain(const std::vector<Eigen::Matrix<double, dim, dim>>& cell_strain) {
  double largest = 0.0;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, dim, dim>> eigen;
  for (const auto& e : cell_strain) {
    eigen.computeDirect(0.5 * (e + e.transpose()), Eigen::EigenvaluesOnly);
    largest = std::max(largest, eigen.eigenvalues().cwiseAbs().maxCoeff());
  }
  return largest;
}

// The warning for the first step whose largest strain exceeds kSmallStrainLimit ("" if none): `who`
// names the run ("needle 'a'", "the static load case"), max_strain has one value per step.
inline std::string small_strain_warning(const std::string& where, const std::string& who,
                                        const std::vector<double>& max_strain) {
  const auto first =
      std::find_if(max_strain.begin(), max_strain.end(), [](double e) { return e > kSmallStrainLimit; });
  if (first == max_strain.end()) return "";
  const double peak = *std::max_element(max_strain.begin(), max_strain.end());
  std::ostringstream w;
  w << where << who << ": the largest strain in the model is " << *first << " at step "
    << first - max_strain.begin() << " (the first step above " << kSmallStrainLimit
    << ", the limit of small-strain elasticity; largest " << peak
    << "): the linear model's displacements and forces are not reliable from there on";
  return w.str();
}

// The warning for a needle whose shaft's near field exceeds kSmallStrainLimit ("" if it never does):
// the radius within which it does (per step), and the targets inside it (target_inside[step][target],
// names in target order).
inline std::string near_field_warning(const std::string& where, const std::string& who,
                                      const std::vector<double>& small_strain_radius,
                                      const std::vector<std::string>& target_names,
                                      const std::vector<std::vector<int>>& target_inside) {
  const auto first =
      std::find_if(small_strain_radius.begin(), small_strain_radius.end(), [](double r) { return r > 0.0; });
  if (first == small_strain_radius.end()) return "";
  const auto peak = std::max_element(small_strain_radius.begin(), small_strain_radius.end());
  std::ostringstream w;
  w << where << who << ": next to the shaft the strain exceeds " << kSmallStrainLimit << " within " << *first
    << " of the axis from step " << first - small_strain_radius.begin() << " (at most " << *peak << ", step "
    << peak - small_strain_radius.begin()
    << "): the linear model is not reliable in that tissue (the shaft's near field, "
       "docs/needle-model.md); ";
  std::string inside;
  for (std::size_t t = 0; t < target_names.size(); ++t)
    for (std::size_t k = 0; k < target_inside.size(); ++k)
      if (target_inside[k][t]) {
        inside += (inside.empty() ? "" : ", ") + target_names[t] + " (from step " + std::to_string(k) + ")";
        break;
      }
  w << (inside.empty() ? "no target lies in it" : "targets in it: " + inside);
  return w.str();
}

}  // namespace vim::pipeline

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

}  // namespace vim::pipeline

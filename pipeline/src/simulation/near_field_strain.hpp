// Private to the simulation sources: the strain of the shaft's near field, which the mesh does not
// resolve (docs/needle-model.md §3 and "Strain next to the shaft"). A station carrying the axial force
// F over the shaft length L it carries, in tissue of shear modulus G, holds the annulus around the
// needle in antiplane shear: at distance r ≥ a from the axis γ_rz = F′/(2πG r), F′ = F/L, whose
// principal strains are ±γ_rz/2 = ±F′/(4πG r). The largest is on the needle's surface (r = a), and the
// strain exceeds the small-strain limit within r_ss = F′/(4πG·kSmallStrainLimit) of the axis.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "simulation/largest_strain.hpp"

namespace vim::pipeline {

struct NearFieldStrain {
  double surface_strain = 0.0;       // the largest principal strain on the needle's surface (r = a)
  double small_strain_radius = 0.0;  // distance from the axis within which the strain exceeds the
                                     // small-strain limit (0: nowhere in the tissue, r_ss ≤ a)
};

// The near field of the active shaft stations (indices into axial_force, carried and shear_modulus;
// stations without a shear modulus, e.g. the tip's rows, and stations carrying no shaft are skipped)
// around a needle of radius a.
inline NearFieldStrain shaft_near_field(const std::vector<std::size_t>& active,
                                        const std::vector<double>& axial_force,
                                        const std::vector<double>& carried,
                                        const std::vector<double>& shear_modulus, double radius) {
  constexpr double pi = 3.14159265358979323846;
  NearFieldStrain field;
  for (std::size_t j : active) {
    if (j >= shear_modulus.size() || !(carried[j] > 0.0) || !(shear_modulus[j] > 0.0)) continue;
    const double strain_times_r = std::abs(axial_force[j]) / carried[j] / (4.0 * pi * shear_modulus[j]);
    field.surface_strain = std::max(field.surface_strain, strain_times_r / radius);
    const double r = strain_times_r / kSmallStrainLimit;
    if (r > radius) field.small_strain_radius = std::max(field.small_strain_radius, r);
  }
  return field;
}

}  // namespace vim::pipeline

// The dose of a brachytherapy seed by the AAPM TG-43U1 formalism in its point-source (1D)
// approximation (M. J. Rivard et al., "Update of AAPM Task Group No. 43 Report", Med. Phys. 31(3),
// 633-674, 2004; docs/dose.md):
//
//   Ḋ(r) = S_K · Λ · (r₀/r)² · g_P(r) · φ_an(r),      r₀ = 1 cm,
//
// with the point-source radial dose function g_P derived from the published line-source one g_L by
// the report's conversion g_P(r) = g_L(r) · [G_L(r, 90°) / G_L(r₀, 90°)] · (r/r₀)². For a permanent
// implant the total dose is D = Ḋ · τ with the mean life τ = T½ / ln 2. Plain C++: no image, no mesh.
#pragma once

#include <string>
#include <vector>

namespace vim::pipeline::dose {

// One tabulated function of r (cm), as printed in the report.
struct RadialTable {
  std::vector<double> r_cm;
  std::vector<double> value;
};

// A seed model's published consensus data.
struct SeedModel {
  std::string name;               // the scenario's name of the model, e.g. "amersham_6711"
  std::string description;        // maker and model
  double dose_rate_constant;      // Λ in cGy h⁻¹ U⁻¹
  double active_length_cm;        // L of the line-source geometry function
  double half_life_days;          // T½ of the nuclide
  RadialTable radial_dose_line;   // g_L(r)
  RadialTable anisotropy_factor;  // φ_an(r)
};

// The models this build knows, by name; an unknown name throws InputError listing the known ones.
const SeedModel& seed_model(const std::string& name);
std::vector<std::string> seed_model_names();

// g_L(r): log-linear interpolation (ln g linear in r) between table entries; below the first entry
// the first value (nearest neighbour), beyond the last the log-linear extrapolation of the last two.
double radial_dose_line(const SeedModel& model, double r_cm);
// φ_an(r): linear interpolation; outside the table the nearest entry's value.
double anisotropy_factor(const SeedModel& model, double r_cm);
// G_L(r, 90°) = 2 atan(L / 2r) / (L r), the line-source geometry function on the transverse axis.
double line_geometry_transverse(double length_cm, double r_cm);
// g_P(r) = g_L(r) · G_L(r, 90°) / G_L(r₀, 90°) · (r/r₀)².
double radial_dose_point(const SeedModel& model, double r_cm);

// Ḋ(r) in cGy/h of one seed of air-kerma strength S_K (U = µGy m² h⁻¹) at r cm. Points closer than
// min_distance_cm (inside the seed's capsule) take the dose rate at that distance.
inline constexpr double min_distance_cm = 0.05;
double dose_rate(const SeedModel& model, double air_kerma_strength, double r_cm);
// τ = T½ / ln 2 in hours: the total dose of a permanent implant is Ḋ₀ τ.
double mean_life_hours(const SeedModel& model);
// The total dose in Gy of one permanent seed at r cm: Ḋ(r) · τ / 100.
double total_dose_gy(const SeedModel& model, double air_kerma_strength, double r_cm);

}  // namespace vim::pipeline::dose

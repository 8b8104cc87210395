#include <algorithm>
#include <cmath>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/dose/tg43.hpp>

namespace vim::pipeline::dose {
namespace {

// AAPM TG-43U1 (Rivard et al., Med. Phys. 31(3), 2004) consensus data of the Amersham (GE
// Healthcare) OncoSeed model 6711, I-125:
//   Λ = 0.965 cGy h⁻¹ U⁻¹ (Table II, consensus dose-rate constants);
//   g_L(r) with L = 0.3 cm (Table III, consensus radial dose functions, values as printed);
//   φ_an(r) (Table V, the φ_an(r) row of the model 6711's F(r, θ) table);
//   T½(I-125) = 59.4 d (the half-life the report uses).
const SeedModel& amersham_6711() {
  static const SeedModel model{
      "amersham_6711",
      "Amersham OncoSeed 6711 (I-125)",
      0.965,
      0.3,
      59.4,
      {{0.10, 0.15, 0.25, 0.50, 0.75, 1.00, 1.50, 2.00, 3.00, 4.00, 5.00, 6.00, 7.00, 8.00, 9.00, 10.00},
       {1.055, 1.078, 1.082, 1.071, 1.042, 1.000, 0.908, 0.814, 0.632, 0.496, 0.364, 0.270, 0.199, 0.148,
        0.109, 0.0803}},
      {{0.5, 1.0, 2.0, 3.0, 4.0, 5.0}, {0.973, 0.944, 0.941, 0.942, 0.943, 0.944}}};
  return model;
}

const std::vector<const SeedModel*>& models() {
  static const std::vector<const SeedModel*> all{&amersham_6711()};
  return all;
}

// The index i of the table interval [r_i, r_{i+1}] that holds r (the last one beyond the table).
std::size_t interval(const RadialTable& t, double r) {
  const auto it = std::upper_bound(t.r_cm.begin(), t.r_cm.end(), r);
  const auto i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - t.r_cm.begin(), 1)) - 1;
  return std::min(i, t.r_cm.size() - 2);
}

}  // namespace

const SeedModel& seed_model(const std::string& name) {
  for (const SeedModel* m : models())
    if (m->name == name) return *m;
  std::string known;
  for (const std::string& n : seed_model_names()) known += (known.empty() ? "" : ", ") + n;
  throw InputError("unknown seed model '" + name + "' (known: " + known + ")");
}

std::vector<std::string> seed_model_names() {
  std::vector<std::string> names;
  for (const SeedModel* m : models()) names.push_back(m->name);
  return names;
}

double radial_dose_line(const SeedModel& model, double r_cm) {
  const RadialTable& t = model.radial_dose_line;
  if (r_cm <= t.r_cm.front()) return t.value.front();
  const std::size_t i = interval(t, r_cm);
  const double s = (r_cm - t.r_cm[i]) / (t.r_cm[i + 1] - t.r_cm[i]);
  return std::exp(std::log(t.value[i]) + s * (std::log(t.value[i + 1]) - std::log(t.value[i])));
}

double anisotropy_factor(const SeedModel& model, double r_cm) {
  const RadialTable& t = model.anisotropy_factor;
  if (r_cm <= t.r_cm.front()) return t.value.front();
  if (r_cm >= t.r_cm.back()) return t.value.back();
  const std::size_t i = interval(t, r_cm);
  const double s = (r_cm - t.r_cm[i]) / (t.r_cm[i + 1] - t.r_cm[i]);
  return t.value[i] + s * (t.value[i + 1] - t.value[i]);
}

double line_geometry_transverse(double length_cm, double r_cm) {
  return 2.0 * std::atan(length_cm / (2.0 * r_cm)) / (length_cm * r_cm);
}

double radial_dose_point(const SeedModel& model, double r_cm) {
  const double L = model.active_length_cm;
  return radial_dose_line(model, r_cm) * line_geometry_transverse(L, r_cm) /
         line_geometry_transverse(L, 1.0) * r_cm * r_cm;
}

double dose_rate(const SeedModel& model, double air_kerma_strength, double r_cm) {
  const double r = std::max(r_cm, min_distance_cm);
  return air_kerma_strength * model.dose_rate_constant / (r * r) * radial_dose_point(model, r) *
         anisotropy_factor(model, r);
}

double mean_life_hours(const SeedModel& model) { return model.half_life_days * 24.0 / std::log(2.0); }

double total_dose_gy(const SeedModel& model, double air_kerma_strength, double r_cm) {
  return dose_rate(model, air_kerma_strength, r_cm) * mean_life_hours(model) / 100.0;
}

}  // namespace vim::pipeline::dose

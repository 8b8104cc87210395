// The TG-43U1 point-source dose and the dose-volume metrics (pipeline/src/dose/).
// Truths: the report's formula Ḋ(r) = S_K Λ (r₀/r)² g_P(r) φ_an(r) evaluated here from the printed
// table entries of the Amersham 6711 (Rivard et al., Med. Phys. 31(3), 2004: Λ Table II, g_L Table III,
// φ_an Table V), with the line-source geometry factor computed from the angle the active length
// subtends; and, for D90/V100/V150, the geometry of a radial dose in a sphere: the volume that
// receives at least D is the ball of radius r(D), found here by bisection.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/dose/dose_volume.hpp>
#include <vim/pipeline/dose/tg43.hpp>

using namespace vim::pipeline;
using namespace vim::pipeline::dose;

namespace {

constexpr double kLambda = 0.965;  // cGy h⁻¹ U⁻¹, TG-43U1 Table II (model 6711)
constexpr double kLength = 0.3;    // cm, the model 6711's L

// G_L(r, 90°) = β / (L r): β the angle the segment of length L subtends at distance r on its bisector,
// here from the two end vectors.
double geometry_line(double r) {
  const double ax = -kLength / 2, bx = kLength / 2;
  const double cos_beta = (ax * bx + r * r) / (std::hypot(ax, r) * std::hypot(bx, r));
  return std::acos(cos_beta) / (kLength * r);
}

// The report's point-source dose rate from given g_L(r) and φ_an(r) values.
double expected_rate(double sk, double r, double g_line, double phi) {
  const double g_point = g_line * geometry_line(r) / geometry_line(1.0) * r * r;
  return sk * kLambda / (r * r) * g_point * phi;
}

}  // namespace

TEST(Tg43Dose, DoseRateOnTheTableMatchesThePrintedValues) {
  const SeedModel& m = seed_model("amersham_6711");
  const double sk = 0.5;
  // r (cm), g_L(r) (Table III) and φ_an(r) (Table V) as printed.
  const std::vector<std::array<double, 3>> rows{
      {{1.0, 1.000, 0.944}}, {{2.0, 0.814, 0.941}}, {{5.0, 0.364, 0.944}}};
  for (const auto& [r, g, phi] : rows) {
    const double expected = expected_rate(sk, r, g, phi);
    EXPECT_NEAR(dose_rate(m, sk, r), expected, 0.005 * expected) << "r = " << r << " cm";
  }
  // At r₀ the dose rate is S_K Λ φ_an(r₀) by definition of Λ and g(r₀) = 1.
  EXPECT_NEAR(dose_rate(m, sk, 1.0), sk * kLambda * 0.944, 1e-12);
}

TEST(Tg43Dose, RadialDoseInterpolatesLogLinearlyAndExtrapolatesByTheStatedRule) {
  const SeedModel& m = seed_model("amersham_6711");
  // Between 2 and 3 cm (0.814, 0.632): ln g linear in r, so at the midpoint the geometric mean.
  EXPECT_NEAR(radial_dose_line(m, 2.5), std::sqrt(0.814 * 0.632), 1e-12);
  EXPECT_NEAR(radial_dose_line(m, 2.25), std::pow(0.814, 0.75) * std::pow(0.632, 0.25), 1e-12);
  // Beyond 10 cm: the last two entries' log-linear extrapolation; below 0.1 cm: the first entry.
  EXPECT_NEAR(radial_dose_line(m, 11.0), 0.0803 * (0.0803 / 0.109), 1e-12);
  EXPECT_NEAR(radial_dose_line(m, 0.07), 1.055, 1e-12);
  // φ_an: linear between entries, the nearest entry outside the table.
  EXPECT_NEAR(anisotropy_factor(m, 2.5), 0.5 * (0.941 + 0.942), 1e-12);
  EXPECT_NEAR(anisotropy_factor(m, 0.2), 0.973, 1e-12);
  EXPECT_NEAR(anisotropy_factor(m, 8.0), 0.944, 1e-12);
  // The dose rate between entries then follows the report's formula with those values.
  const double expected = expected_rate(0.7, 2.5, std::sqrt(0.814 * 0.632), 0.9415);
  EXPECT_NEAR(dose_rate(m, 0.7, 2.5), expected, 1e-9 * expected);
}

TEST(Tg43Dose, PermanentImplantDoseIsTheInitialRateTimesTheMeanLife) {
  const SeedModel& m = seed_model("amersham_6711");
  const double tau_h = 59.4 * 24.0 / std::log(2.0);  // I-125: T½ = 59.4 d
  EXPECT_NEAR(mean_life_hours(m), tau_h, 1e-9);
  EXPECT_NEAR(total_dose_gy(m, 0.5, 1.0), 0.5 * kLambda * 0.944 * tau_h / 100.0, 1e-9);
  // Two seeds: superposition.
  const std::vector<Point> seeds{{{0, 0, 0}}, {{0, 0, 20}}};
  EXPECT_NEAR(seeds_dose_gy(m, 0.5, seeds, {{10, 0, 0}}),
              total_dose_gy(m, 0.5, 1.0) + total_dose_gy(m, 0.5, std::sqrt(5.0)), 1e-9);
}

TEST(Tg43Dose, D90V100V150OfASphereAroundOneSeedMatchTheBallRadii) {
  const SeedModel& m = seed_model("amersham_6711");
  const double sk = 10.0, prescription = 145.0, radius = 15.0;  // U, Gy (TG-137), mm
  const auto dose = [&](double r_mm) { return total_dose_gy(m, sk, r_mm / 10.0); };
  // r(D): the radius at which the (decreasing) radial dose equals D.
  const auto radius_of = [&](double level) {
    double lo = 0.5, hi = 100.0;
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      (dose(mid) >= level ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  for (double r = 0.6; r < 30; r += 0.1) ASSERT_GT(dose(r), dose(r + 0.1)) << "the dose must fall with r";
  const Point seed{{0.13, -0.21, 0.37}};  // off the grid's nodes
  std::vector<double> doses;
  const double h = 0.5;
  for (double x = -radius; x <= radius; x += h)
    for (double y = -radius; y <= radius; y += h)
      for (double z = -radius; z <= radius; z += h) {
        const Point p{{seed[0] + x + 0.5 * h, seed[1] + y + 0.25 * h, seed[2] + z + 0.125 * h}};
        const double dx = p[0] - seed[0], dy = p[1] - seed[1], dz = p[2] - seed[2];
        if (dx * dx + dy * dy + dz * dz <= radius * radius) doses.push_back(seeds_dose_gy(m, sk, {seed}, p));
      }
  const DoseVolumeMetrics got = dose_volume_metrics(doses, prescription);
  const double d90 = dose(radius * std::cbrt(0.9));
  const double v100 = 100.0 * std::pow(radius_of(prescription) / radius, 3);
  const double v150 = 100.0 * std::pow(radius_of(1.5 * prescription) / radius, 3);
  ASSERT_GT(v100, 20.0);
  ASSERT_LT(v100, 80.0);
  std::cout << "sphere of " << radius << " mm, " << doses.size() << " points: D90 " << got.d90_gy
            << " Gy (analytic " << d90 << "), V100 " << got.v100_percent << "% (" << v100 << "), V150 "
            << got.v150_percent << "% (" << v150 << ")\n";
  EXPECT_NEAR(got.d90_gy, d90, 0.02 * d90);
  EXPECT_NEAR(got.v100_percent, v100, 0.02 * v100);
  EXPECT_NEAR(got.v150_percent, v150, 0.02 * v150);
}

TEST(Tg43Dose, UnknownSeedModelNamesTheKnownOnes) {
  try {
    seed_model("best_2301");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'best_2301'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("amersham_6711"), std::string::npos) << e.what();
  }
}

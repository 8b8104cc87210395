// The tip bearing's closed forms (vim/needle/tip_bearing.hpp) against quadrature: the mean over a disk
// of radius R of the displacement of a uniform unit load over it is c(ν)/E · E[1/|x − y|] with
// E[1/|x − y|] over two points of the disk computed here in polar coordinates about x
// (∫ dy/|x − y| = ∫₀^{2π} ρ(x, θ) dθ, ρ the distance from x to the circle along θ); c = (1 − ν²)/π
// on the surface (Boussinesq), (3 − 4ν)/(16πG(1 − ν))·E in a full space (Kelvin, in the disk's plane).
// The row: a uniform mean over the disk (its samples' weighted second moment R²/2) and the compliance
// C_punch − C_disk, so that in series with the disk's own compliance the total is the punch's.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vim/fem/material.hpp>
#include <vim/needle/tip_bearing.hpp>

using namespace vim;
using namespace vim::needle;

namespace {

constexpr double kPi = 3.14159265358979323846;

// E[1/|x − y|] for x, y uniform over the disk of radius R (midpoint rule in r, θ about the centre and
// in the direction about x).
double mean_inverse_distance(double R) {
  const int n = 200;
  double sum = 0.0, area = 0.0;
  for (int i = 0; i < n; ++i) {
    const double r = (i + 0.5) * R / n;
    for (int j = 0; j < n; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / n;
      const double x = r * std::cos(phi), y = r * std::sin(phi);
      double line = 0.0;
      for (int k = 0; k < n; ++k) {
        const double t = 2.0 * kPi * (k + 0.5) / n;
        const double b = x * std::cos(t) + y * std::sin(t);
        line += -b + std::sqrt(R * R - r * r + b * b);
      }
      sum += r * line * 2.0 * kPi / n;
      area += r;
    }
  }
  return sum / area / (kPi * R * R);
}

}  // namespace

TEST(TipBearing, DiskAndPunchCompliancesAgainstQuadrature) {
  const double E = 30.0, nu = 0.3, R = 2.0, G = fem::shear_modulus(E, nu);
  const double m = mean_inverse_distance(R);
  EXPECT_NEAR(m, 16.0 / (3.0 * kPi * R), 1e-4 * m);
  EXPECT_NEAR(disk_compliance(R, E, nu, 0.0), (1.0 - nu * nu) / (kPi * E) * m, 1e-4 * m / E);
  const double full = (3.0 - 4.0 * nu) / (16.0 * kPi * G * (1.0 - nu)) * m;
  EXPECT_NEAR(disk_compliance(R, E, nu, std::numeric_limits<double>::infinity()), full, 1e-4 * full);
  // Between: from the surface value down to the full space's, monotonically.
  double last = disk_compliance(R, E, nu, 0.0);
  for (double t : {0.1, 1.0, 10.0, 1000.0}) {
    const double c = disk_compliance(R, E, nu, t);
    EXPECT_LT(c, last);
    EXPECT_GT(c, full);
    last = c;
  }
  EXPECT_DOUBLE_EQ(punch_compliance(0.635, E, nu), (1.0 - nu * nu) / (2.0 * 0.635 * E));
}

TEST(TipBearing, RowIsTheUniformDiskMeanInSeriesWithTheRestOfThePunch) {
  const double E = 30.0, nu = 0.3, a = 0.635, R = 2.0;
  const Vec<3> axis = Vec<3>(1.0, -2.0, 0.5).normalized();
  const auto p = tip_bearing_constraint(Vec<3>(1, 2, 3), axis, a, R, 0.2, E, nu, 0.0);
  EXPECT_FALSE(p.components[0]);
  EXPECT_FALSE(p.components[1]);
  EXPECT_TRUE(p.components[2]);
  EXPECT_LT((p.axes.col(2) - axis).norm(), 1e-14);
  double w = 0.0, second = 0.0;
  for (std::size_t q = 0; q < p.offsets.size(); ++q) {
    EXPECT_NEAR(p.offsets[q].dot(axis), 0.0, 1e-12);
    EXPECT_LE(p.offsets[q].norm(), R);
    w += p.weights[q];
    second += p.weights[q] * p.offsets[q].squaredNorm();
  }
  EXPECT_NEAR(second / w, 0.5 * R * R, 0.01 * R * R);  // a uniform disk: E[r²] = R²/2
  EXPECT_DOUBLE_EQ(p.compliance[2], punch_compliance(a, E, nu) - disk_compliance(R, E, nu, 0.0));
  EXPECT_THROW(tip_bearing_constraint(Vec<3>::Zero(), axis, a, 1.0 * a, 0.2, E, nu, 0.0),
               std::invalid_argument);
  EXPECT_THROW(tip_bearing_constraint(Vec<3>::Zero(), axis, a, R, 0.2, E, nu, -1.0), std::invalid_argument);
}

// The Kelvin field of a force spread over a needle band (vim/needle/band_load_field.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vim/fem/material.hpp>
#include <vim/needle/band_load_field.hpp>

namespace vim::needle {

namespace {

constexpr double pi = 3.14159265358979323846;
constexpr int kAround = 64;  // trapezoid points around the axis (spectral for the periodic integrand)

// Gauss–Legendre nodes and weights on [−1, 1] for n points (Newton on P_n from Chebyshev guesses).
std::vector<std::array<double, 2>> gauss_legendre(int n) {
  std::vector<std::array<double, 2>> q;
  for (int i = 0; i < n; ++i) {
    double x = std::cos(pi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double step = p1 / dp;
      x -= step;
      if (std::abs(step) < 1e-15) break;
    }
    q.push_back({{x, 2.0 / ((1.0 - x * x) * dp * dp)}});
  }
  return q;
}

}  // namespace

Vec<3> kelvin_displacement(const Vec<3>& r, const Vec<3>& force, double youngs_modulus,
                           double poisson_ratio) {
  const double g = fem::shear_modulus(youngs_modulus, poisson_ratio), d2 = r.squaredNorm(), d = std::sqrt(d2);
  if (d2 == 0.0) return Vec<3>::Zero();
  return ((3.0 - 4.0 * poisson_ratio) * force + (r.dot(force) / d2) * r) /
         (16.0 * pi * g * (1.0 - poisson_ratio) * d);
}

namespace {

struct LoadRegion {
  Eigen::Matrix3d frame;  // (lateral 1, lateral 2, axis)
  Vec<3> centre;
  double r0, r1, area;  // radii of the cross-section, its area (2π r1 on a surface)
  bool surface;
};

// The load's mean Kelvin field at x over the cross-sections of the region between z0 and z1 (axial
// offsets from the centre), times their share (z1 − z0)/ℓ of the band — Gauss–Legendre along the axis
// on a piece no longer than its distance from x (halved until it is), across by Gauss–Legendre, around
// by the trapezoid rule.
Vec<3> slab_field(const LoadRegion& g, double z0, double z1, const Vec<3>& x, const Vec<3>& f, double e,
                  double nu, int depth) {
  static const auto along = gauss_legendre(8), across = gauss_legendre(6);
  const Vec<3> d = x - g.centre;
  const double zx = d.dot(g.frame.col(2)), rx = (d - zx * g.frame.col(2)).norm();
  const double gz = std::max({0.0, z0 - zx, zx - z1}), gr = std::max({0.0, rx - g.r1, g.r0 - rx});
  if (z1 - z0 > std::hypot(gz, gr) && depth < 40) {
    const double zm = 0.5 * (z0 + z1);
    return slab_field(g, z0, zm, x, f, e, nu, depth + 1) + slab_field(g, zm, z1, x, f, e, nu, depth + 1);
  }
  Vec<3> u = Vec<3>::Zero();
  for (const auto& [tz, wz] : along) {
    const Vec<3> on_axis = g.centre + (0.5 * (z0 + z1) + 0.5 * tz * (z1 - z0)) * g.frame.col(2);
    for (std::size_t j = 0; j < (g.surface ? 1 : across.size()); ++j) {
      const double r = g.surface ? g.r1 : g.r0 + 0.5 * (across[j][0] + 1.0) * (g.r1 - g.r0);
      const double wr = g.surface ? g.r1 : 0.5 * across[j][1] * (g.r1 - g.r0) * r;
      for (int i = 0; i < kAround; ++i) {
        const double th = 2.0 * pi * i / kAround;
        const Vec<3> y = on_axis + r * (std::cos(th) * g.frame.col(0) + std::sin(th) * g.frame.col(1));
        u += (0.5 * wz * (z1 - z0) * wr * (2.0 * pi / kAround)) * kelvin_displacement(x - y, f, e, nu);
      }
    }
  }
  return u / g.area;
}

}  // namespace

Vec<3> band_load_displacement(const NeedleBand& band, const Vec<3>& centre, const Vec<3>& axis,
                              const Vec<3>& force, const Vec<3>& x, double youngs_modulus,
                              double poisson_ratio) {
  if (!(band.length > 0.0) || !(band.coupling_radius > 0.0) || !(band.inner_fraction >= 0.0) ||
      !(band.inner_fraction <= 1.0))
    throw std::invalid_argument(
        "band load: the band needs a length > 0, a radius > 0 and an inner fraction in [0, 1]");
  if (!(youngs_modulus > 0.0) || !(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    throw std::invalid_argument("band load: E must be > 0 and ν in (−1, 0.5), got " +
                                std::to_string(youngs_modulus) + " and " + std::to_string(poisson_ratio));
  LoadRegion g;
  g.frame = needle_frame(axis);
  g.centre = centre;
  g.r1 = band.coupling_radius;
  g.r0 = band.inner_fraction * g.r1;
  g.surface = g.r1 - g.r0 <= 1e-12 * g.r1;
  // Per unit length of the band: the slabs' weights sum to ℓ.
  g.area = (g.surface ? 2.0 * pi * g.r1 : pi * (g.r1 * g.r1 - g.r0 * g.r0)) * band.length;
  return slab_field(g, -0.5 * band.length, 0.5 * band.length, x, force, youngs_modulus, poisson_ratio, 0);
}

}  // namespace vim::needle

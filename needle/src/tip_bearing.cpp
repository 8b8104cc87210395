// The tip's end bearing (vim/needle/tip_bearing.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vim/fem/material.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/needle/tip_bearing.hpp>

namespace vim::needle {

namespace {
constexpr double pi = 3.14159265358979323846;

void check_material(double youngs_modulus, double poisson_ratio) {
  if (!(youngs_modulus > 0.0) || !std::isfinite(youngs_modulus) ||
      !(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    throw std::invalid_argument("tip bearing: needs E > 0 and -1 < ν < 0.5, got E = " +
                                std::to_string(youngs_modulus) + ", ν = " + std::to_string(poisson_ratio));
}
}  // namespace

double punch_compliance(double radius, double youngs_modulus, double poisson_ratio) {
  check_material(youngs_modulus, poisson_ratio);
  return (1.0 - poisson_ratio * poisson_ratio) / (2.0 * radius * youngs_modulus);
}

double disk_compliance(double disk_radius, double youngs_modulus, double poisson_ratio, double depth) {
  check_material(youngs_modulus, poisson_ratio);
  const double nu = poisson_ratio, e = youngs_modulus;
  const double surface = 16.0 * (1.0 - nu * nu) / (3.0 * pi * pi * disk_radius * e);
  const double full =
      (3.0 - 4.0 * nu) / (3.0 * pi * pi * fem::shear_modulus(e, nu) * (1.0 - nu) * disk_radius);
  if (!(depth > 0.0)) return surface;
  if (std::isinf(depth)) return full;
  const double mindlin = (1.0 + nu) *
                         (0.5 * (8.0 * (1.0 - nu) * (1.0 - nu) - 3.0 + 4.0 * nu) +
                          0.125 * (4.0 * (3.0 - 4.0 * nu) - 2.0) + 0.75) /
                         (8.0 * pi * (1.0 - nu));
  const double t0 = mindlin / (e * (surface - full));
  return full + (surface - full) / (1.0 + depth / t0);
}

PointConstraint<3> tip_bearing_constraint(const Vec<3>& centre, const Vec<3>& axis, double radius,
                                          double disk_radius, double spacing, double youngs_modulus,
                                          double poisson_ratio, double depth) {
  if (!(radius > 0.0) || !(disk_radius >= kMinTipDiskRatio * radius) || !std::isfinite(disk_radius) ||
      !(spacing > 0.0) || !(depth >= 0.0))
    throw std::invalid_argument(
        "tip bearing: needs a > 0, R >= 1.1 a, a sample spacing > 0 and a depth >= 0, got a = " +
        std::to_string(radius) + ", R = " + std::to_string(disk_radius) +
        ", spacing = " + std::to_string(spacing) + ", depth = " + std::to_string(depth));
  PointConstraint<3> p;
  p.position = centre;
  p.axes = needle_frame(axis);
  p.components = {{false, false, true}};
  const int n_radial = std::max(2, static_cast<int>(std::ceil(disk_radius / spacing)));
  const double dr = disk_radius / n_radial;
  for (int j = 0; j < n_radial; ++j) {
    const double r = (j + 0.5) * dr;
    const int n_theta = std::max(8, static_cast<int>(std::ceil(2.0 * pi * r / spacing)));
    for (int k = 0; k < n_theta; ++k) {
      const double t = 2.0 * pi * (k + 0.5 * (j % 2)) / n_theta;
      p.offsets.push_back(r * (std::cos(t) * p.axes.col(0) + std::sin(t) * p.axes.col(1)));
      p.weights.push_back(r / n_theta);  // a uniform mean over the disk: ring weight ∝ r
    }
  }
  p.compliance =
      Vec<3>(0.0, 0.0, tip_bearing_compliance(radius, disk_radius, youngs_modulus, poisson_ratio, depth));
  return p;
}

double tip_bearing_compliance(double radius, double disk_radius, double youngs_modulus, double poisson_ratio,
                              double depth) {
  const double kappa = punch_compliance(radius, youngs_modulus, poisson_ratio) -
                       disk_compliance(disk_radius, youngs_modulus, poisson_ratio, depth);
  return std::max(0.0, kappa);
}

double tip_disk_radius(double band_radius, double radius) { return std::max(band_radius, 2.0 * radius); }

double tip_sample_spacing(double element_size, double disk_radius) {
  return 0.5 * (element_size > 0.0 ? std::min(element_size, disk_radius) : disk_radius);
}

double free_surface_along(const CellLocator<3>& locator, const Vec<3>& entry, const Vec<3>& axis,
                          double length) {
  if (locator.locate(entry - 1e-6 * length * axis) >= 0) return -std::numeric_limits<double>::infinity();
  const double dt = 1e-3 * length;
  double surface = 0.0;
  while (surface < length && locator.locate(entry + surface * axis) < 0) surface += dt;
  return surface;
}

}  // namespace vim::needle

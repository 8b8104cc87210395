// Finite-radius needle coupling rows (vim/fem/needle_band.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vim/fem/needle_band.hpp>

namespace vim::fem {

namespace {

constexpr double pi = 3.14159265358979323846;
// Measured (docs/needle-model.md): the smallest R/h that keeps the analytic shafts within 2–3%.
constexpr double kCouplingFactorP1 = 1.0;
constexpr double kCouplingFactorP2 = 1.0;
constexpr double kSampleSpacing = 0.5;  // samples per element size h: spacing ≤ 0.5 h

void check_band(double radius, double coupling_radius, double length) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("needle band: the radius must be finite and > 0, got " +
                                std::to_string(radius));
  if (!(coupling_radius >= radius) || !std::isfinite(coupling_radius))
    throw std::invalid_argument("needle band: the coupling radius must be finite and ≥ the radius " +
                                std::to_string(radius) + ", got " + std::to_string(coupling_radius));
  if (!(length > 0.0) || !std::isfinite(length))
    throw std::invalid_argument("needle band: the length must be finite and > 0, got " +
                                std::to_string(length));
}

double shear_modulus(double youngs_modulus, double poisson_ratio) {
  return youngs_modulus / (2.0 * (1.0 + poisson_ratio));
}

}  // namespace

double axial_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                             double poisson_ratio) {
  check_band(radius, coupling_radius, length);
  const double g = shear_modulus(youngs_modulus, poisson_ratio);
  return std::log(coupling_radius / radius) / (2.0 * pi * g * length);
}

double lateral_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                               double poisson_ratio) {
  check_band(radius, coupling_radius, length);
  const double g = shear_modulus(youngs_modulus, poisson_ratio);
  return (3.0 - 4.0 * poisson_ratio) * std::log(coupling_radius / radius) /
         (8.0 * pi * g * (1.0 - poisson_ratio) * length);
}

double default_coupling_radius(double radius, double element_size, unsigned degree) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("needle band: the radius must be finite and > 0, got " +
                                std::to_string(radius));
  if (!(element_size > 0.0) || !std::isfinite(element_size))
    throw std::invalid_argument("needle band: the element size must be finite and > 0, got " +
                                std::to_string(element_size));
  if (degree != 1 && degree != 2)
    throw std::invalid_argument("needle band: the element degree must be 1 or 2, got " +
                                std::to_string(degree));
  const double c = degree == 1 ? kCouplingFactorP1 : kCouplingFactorP2;
  return std::max(radius, c * element_size);
}

NeedleBand default_needle_band(double radius, double element_size, double length, unsigned degree) {
  NeedleBand band;
  band.radius = radius;
  band.coupling_radius = default_coupling_radius(radius, element_size, degree);
  band.length = length;
  check_band(band.radius, band.coupling_radius, band.length);
  const double spacing = kSampleSpacing * element_size;
  band.n_theta = std::max(8, static_cast<int>(std::ceil(2.0 * pi * band.coupling_radius / spacing)));
  band.n_axial = std::max(2, static_cast<int>(std::ceil(length / spacing)));
  return band;
}

Eigen::Matrix3d needle_frame(const Vec<3>& axis) {
  const Vec<3> z = axis.normalized();
  // The world axis least aligned with the needle, made orthogonal to it.
  Eigen::Index k = 0;
  z.cwiseAbs().minCoeff(&k);
  Vec<3> x = Vec<3>::Unit(k) - z[k] * z;
  x.normalize();
  Eigen::Matrix3d f;
  f.col(0) = x;
  f.col(1) = z.cross(x);
  f.col(2) = z;
  return f;
}

PointConstraint<3> needle_band_constraint(const Vec<3>& centre, const Vec<3>& axis, const NeedleBand& band,
                                          const Vec<3>& displacement, double youngs_modulus,
                                          double poisson_ratio) {
  check_band(band.radius, band.coupling_radius, band.length);
  if (band.n_theta < 3 || band.n_axial < 1)
    throw std::invalid_argument("needle band: at least 3 samples around and 1 along the axis are needed");
  PointConstraint<3> p;
  p.position = centre;
  p.axes = needle_frame(axis);
  p.displacement = displacement;
  // Rings at the midpoints of n_axial equal parts of the band (stations tiling a path then sample it
  // evenly), each rotated by half a sample against the previous one; equal weights.
  for (int k = 0; k < band.n_axial; ++k) {
    const double t = (k + 0.5) / band.n_axial - 0.5;
    for (int i = 0; i < band.n_theta; ++i) {
      const double th = 2.0 * pi * (i + 0.5 * k) / band.n_theta;
      p.offsets.push_back(band.coupling_radius *
                              (std::cos(th) * p.axes.col(0) + std::sin(th) * p.axes.col(1)) +
                          t * band.length * p.axes.col(2));
      p.weights.push_back(1.0);
    }
  }
  const double kl =
      lateral_band_compliance(band.radius, band.coupling_radius, band.length, youngs_modulus, poisson_ratio);
  p.compliance = Vec<3>(
      kl, kl,
      axial_band_compliance(band.radius, band.coupling_radius, band.length, youngs_modulus, poisson_ratio));
  return p;
}

}  // namespace vim::fem

// Finite-radius needle coupling rows (vim/needle/needle_band.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>
#include <vim/fem/material.hpp>
#include <vim/needle/needle_band.hpp>

namespace vim::needle {

namespace {

constexpr double pi = 3.14159265358979323846;
// Measured (docs/needle-model.md): the smallest R/h that keeps the analytic shafts within 2–3%.
constexpr double kCouplingFactorP1 = 3.0;
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

// The rings of the band's cross-section: radius and weight (summing to 1).
std::vector<std::pair<double, double>> band_rings(const NeedleBand& band) {
  check_band(band.radius, band.coupling_radius, band.length);
  if (band.n_radial < 1 || !(band.inner_fraction >= 0.0 && band.inner_fraction <= 1.0))
    throw std::invalid_argument("needle band: at least 1 ring across, and an inner fraction in [0, 1], got " +
                                std::to_string(band.n_radial) + " and " +
                                std::to_string(band.inner_fraction));
  const double r0 = band.inner_fraction * band.coupling_radius,
               dr = (band.coupling_radius - r0) / band.n_radial;
  std::vector<std::pair<double, double>> rings;
  double sum = 0.0;
  for (int j = 0; j < band.n_radial; ++j) {
    const double r = r0 + (j + 0.5) * dr;
    rings.emplace_back(r, r);
    sum += r;
  }
  for (auto& ring : rings) ring.second /= sum;
  return rings;
}

}  // namespace

double axial_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                             double poisson_ratio) {
  check_band(radius, coupling_radius, length);
  const double g = fem::shear_modulus(youngs_modulus, poisson_ratio);
  return std::log(coupling_radius / radius) / (2.0 * pi * g * length);
}

double lateral_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                               double poisson_ratio) {
  check_band(radius, coupling_radius, length);
  const double g = fem::shear_modulus(youngs_modulus, poisson_ratio);
  return (3.0 - 4.0 * poisson_ratio) * std::log(coupling_radius / radius) /
         (8.0 * pi * g * (1.0 - poisson_ratio) * length);
}

double effective_coupling_radius(const NeedleBand& band) {
  double log_r = 0.0;
  for (const auto& [r, w] : band_rings(band))
    for (const auto& [s, v] : band_rings(band)) log_r += w * v * std::log(std::max(r, s));
  return std::exp(log_r);
}

NeedleBand needle_band_for(double radius, double element_size, double length, double c) {
  if (!(element_size > 0.0) || !std::isfinite(element_size) || !(c > 0.0) || !std::isfinite(c))
    throw std::invalid_argument("needle band: the element size and its factor must be finite and > 0, got " +
                                std::to_string(element_size) + " and " + std::to_string(c));
  NeedleBand band;
  band.radius = radius;
  band.length = length;
  band.coupling_radius = std::max(radius, c * element_size);
  check_band(band.radius, band.coupling_radius, band.length);
  const double spacing = kSampleSpacing * element_size, thickness = c * element_size;
  // The smallest R ≥ c·h whose shell of thickness min(R, c·h) has an effective radius ≥ a (R_e/R only
  // grows with R here, so the fixed point is reached from below).
  for (int it = 0; it < 50; ++it) {
    const double R = band.coupling_radius;
    band.inner_fraction = std::max(0.0, R - thickness) / R;
    band.n_radial = std::max(1, static_cast<int>(std::ceil((R - band.inner_fraction * R) / spacing)));
    const double grown = std::max(c * element_size, radius * R / effective_coupling_radius(band));
    if (std::abs(grown - R) <= 1e-12 * R) break;
    band.coupling_radius = grown;
  }
  // A multiple of 4: the samples keep the symmetries of a square grid around the needle (quarter turns
  // and mirrors about the frame's axes and diagonals), so symmetric problems stay symmetric.
  band.n_theta =
      4 * std::max(2, static_cast<int>(std::ceil(2.0 * pi * band.coupling_radius / spacing / 4.0)));
  band.n_axial = std::max(2, static_cast<int>(std::ceil(length / spacing)));
  return band;
}

NeedleBand default_needle_band(double radius, double element_size, double length, unsigned degree) {
  if (degree != 1 && degree != 2)
    throw std::invalid_argument("needle band: the element degree must be 1 or 2, got " +
                                std::to_string(degree));
  return needle_band_for(radius, element_size, length, degree == 1 ? kCouplingFactorP1 : kCouplingFactorP2);
}

double default_coupling_radius(double radius, double element_size, unsigned degree) {
  return default_needle_band(radius, element_size, element_size, degree).coupling_radius;
}

NeedleBand station_band(double radius, double coupling_radius, double element_size, double length,
                        unsigned degree) {
  if (!(coupling_radius > 0.0)) return default_needle_band(radius, element_size, length, degree);
  NeedleBand band;
  band.radius = radius;
  band.coupling_radius = coupling_radius;
  band.length = length;
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
  // evenly) and at the band's radii, each rotated by half a sample against the previous one.
  const auto rings = band_rings(band);
  for (int k = 0; k < band.n_axial; ++k) {
    const double t = (k + 0.5) / band.n_axial - 0.5;
    for (std::size_t j = 0; j < rings.size(); ++j)
      for (int i = 0; i < band.n_theta; ++i) {
        const double th = 2.0 * pi * (i + 0.5 * static_cast<double>(k + j)) / band.n_theta;
        p.offsets.push_back(rings[j].first * (std::cos(th) * p.axes.col(0) + std::sin(th) * p.axes.col(1)) +
                            t * band.length * p.axes.col(2));
        p.weights.push_back(rings[j].second);
      }
  }
  const double re = effective_coupling_radius(band);
  if (!(re >= band.radius * (1.0 - 1e-12)))
    throw std::invalid_argument("needle band: the effective radius " + std::to_string(re) +
                                " of the averaging shell is below the needle's radius " +
                                std::to_string(band.radius) + " (move the shell outwards)");
  // A shell whose effective radius is the needle's (needle_band_for when h ≪ a) is held rigidly: κ = 0
  // exactly, not a round-off compliance, so the fast and monolithic solves treat its rows alike.
  const double r_eff = re <= band.radius * (1.0 + 1e-9) ? band.radius : re;
  const double kl = lateral_band_compliance(band.radius, r_eff, band.length, youngs_modulus, poisson_ratio);
  p.compliance =
      Vec<3>(kl, kl, axial_band_compliance(band.radius, r_eff, band.length, youngs_modulus, poisson_ratio));
  return p;
}

namespace {

// The edge of the cube of the cell's volume: (6V)^(1/3) for a tetrahedron (4 support vertices),
// V^(1/3) for a grid cell (the bounding box of its 8 vertices).
double cell_size(const CellLocator<3>& locator, const std::vector<int>& support) {
  if (support.size() == 4) {
    Eigen::Matrix3d e;
    for (int k = 0; k < 3; ++k) e.col(k) = locator.vertex(support[k + 1]) - locator.vertex(support[0]);
    return std::cbrt(std::abs(e.determinant()));
  }
  Eigen::Vector3d lo = locator.vertex(support.front()), hi = lo;
  for (int v : support) lo = lo.cwiseMin(locator.vertex(v)), hi = hi.cwiseMax(locator.vertex(v));
  return std::cbrt((hi - lo).prod());
}

}  // namespace

double path_element_size(const CellLocator<3>& locator, const Eigen::Vector3d& entry,
                         const Eigen::Vector3d& axis, double depth) {
  // Points every quarter of the mean edge: every cell the path crosses over more than that is seen. They
  // lie a thousandth of an edge off the path, so that a path along mesh edges or faces still finds
  // points inside cells (whose support is the whole cell).
  const double step = std::max(0.25 * locator.mean_edge_length(), 1e-6 * depth);
  const Eigen::Matrix3d frame = needle_frame(axis);
  const Eigen::Vector3d off = 1e-3 * locator.mean_edge_length() * (0.54 * frame.col(0) + 0.84 * frame.col(1));
  std::set<long> seen;
  std::vector<int> support;
  double sum = 0.0;
  for (double s = 0.5 * step; s < depth; s += step) {
    const long c = locator.locate(entry + s * axis + off, &support);
    if (c < 0 || support.size() < 4 || !seen.insert(c).second) continue;
    sum += cell_size(locator, support);
  }
  return seen.empty() ? locator.mean_edge_length() : sum / static_cast<double>(seen.size());
}

}  // namespace vim::needle

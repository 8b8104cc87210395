// The coupling of a rigid needle of finite radius to a 3D model (docs/needle-model.md): one shaft
// station holds the mean displacement of a band of the cylinder of coupling radius R ≥ a around the
// needle axis (a surface average, which carries force in the continuum where a line does not), through
// the analytic compliance of the tissue annulus a ≤ r ≤ R in series:
//   axial    κ_z = ln(R/a) / (2πG ℓ)                     (antiplane shear of a rigid shaft)
//   lateral  κ_x = (3 − 4ν) ln(R/a) / (8πG(1 − ν) ℓ)     (plane strain, Kelvin line force)
// with ℓ the band's length and G = E / (2(1 + ν)). R = a is the bare surface average (mesh fine near
// the path); R > a lets meshes much coarser than the needle carry the needle's force. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <vim/fem/point_constraints.hpp>

namespace vim::fem {

struct NeedleBand {
  double radius = 0.0;           // a: the needle's radius
  double coupling_radius = 0.0;  // R ≥ a: the cylinder whose band mean the station holds
  double length = 0.0;           // ℓ > 0: the band's extent along the axis
  int n_theta = 8;               // samples around the circle
  int n_axial = 2;  // rings along the band (midpoint rule: ring k at (k + ½)/n_axial − ½ of ℓ)
};

// The coupling radius for a needle of radius a whose path runs through elements of size h (the edge
// length near the path) of degree 1 or 2: R = max(a, c·h), c measured on the analytic antiplane and
// lateral shafts (docs/needle-model.md). Throws std::invalid_argument for a ≤ 0, h ≤ 0 or another degree.
double default_coupling_radius(double radius, double element_size, unsigned degree);

// The default band of a station of length ℓ: default_coupling_radius, and samples spaced at most about
// h/2 around the circle and along the band (the mean of the field then resolves the elements it crosses).
NeedleBand default_needle_band(double radius, double element_size, double length, unsigned degree);

// Compliances (displacement per unit force) of the annulus a ≤ r ≤ R over a band of length ℓ.
double axial_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                             double poisson_ratio);
double lateral_band_compliance(double radius, double coupling_radius, double length, double youngs_modulus,
                               double poisson_ratio);

// The averaged constraint of one station centred at `centre` on a needle along the unit vector
// `axis`: axes = (two lateral directions, axis), all three components held, displacement given in those
// axes (lateral_1, lateral_2, axial), compliances from the modulus around the station. Throws
// std::invalid_argument for radius ≤ 0, coupling_radius < radius, length ≤ 0 or too few samples.
PointConstraint<3> needle_band_constraint(const Vec<3>& centre, const Vec<3>& axis, const NeedleBand& band,
                                          const Vec<3>& displacement, double youngs_modulus,
                                          double poisson_ratio);

// Two unit vectors completing the unit `axis` to a right-handed orthonormal frame (lateral_1, lateral_2,
// axis).
Eigen::Matrix3d needle_frame(const Vec<3>& axis);

}  // namespace vim::fem

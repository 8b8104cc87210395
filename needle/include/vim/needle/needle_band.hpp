// The coupling of a rigid needle of finite radius a to a 3D model (docs/needle-model.md): one shaft
// station holds the mean displacement over a band of length ℓ of a cylindrical shell around the needle
// axis (outer radius R; a surface or volume mean, which carries force in the continuum where a line does
// not), through the analytic compliance of the tissue between the needle and the shell in series:
//   axial    κ_z = ln(R_e/a) / (2πG ℓ)                     (antiplane shear of a rigid shaft)
//   lateral  κ_x = (3 − 4ν) ln(R_e/a) / (8πG(1 − ν) ℓ)     (plane strain: Kelvin line force + dipole)
// with G = E / (2(1 + ν)) and R_e the shell's effective radius (R for a single ring). A ring at R = a is
// the bare surface mean (meshes fine near the path); larger shells let meshes much coarser than the
// needle carry the needle's force. default_needle_band chooses the shell from the element size.
// deal.II-free.
#pragma once

#include <Eigen/Core>
#include <vim/needle/fem_types.hpp>

namespace vim::needle {

struct NeedleBand {
  double radius = 0.0;           // a: the needle's radius
  double coupling_radius = 0.0;  // R ≥ a: the outer radius of the region whose mean the station holds
  double length = 0.0;           // ℓ > 0: the band's extent along the axis
  int n_theta = 8;               // samples around each ring
  int n_axial = 2;  // rings along the band (midpoint rule: ring k at (k + ½)/n_axial − ½ of ℓ)
  // The averaging region across the axis: n_radial rings at the midpoints of equal radial parts of
  // [inner_fraction·R, R], weighted by their radius (a uniform mean over the shell's cross-section).
  // inner_fraction = 1 (n_radial = 1) is the cylinder surface of radius R; 0 a solid cylinder.
  double inner_fraction = 1.0;
  int n_radial = 1;
};

// The effective radius R_e of the band's cross-section: ln R_e = Σ_j Σ_k w_j w_k ln max(r_j, r_k) over its
// rings (radius r_j, weight w_j). A load spread over the rings like the mean's weights has that mean equal
// to a ring load's at R_e; the compliances use R_e in place of R (R_e = R for one ring, 0.7788 R for a
// solid cylinder). Throws std::invalid_argument for a bad band.
double effective_coupling_radius(const NeedleBand& band);

// The band of a station of length ℓ for a needle of radius a whose path runs through elements of size h
// (the edge length near the path): a shell of thickness t = min(R, c·h) whose outer radius R is the
// smallest ≥ c·h with an effective radius ≥ a (h ≫ a: a solid cylinder of radius c·h; h ≪ a: a thin
// shell around the needle's surface), samples spaced at most h/2 around, across and along.
// Throws std::invalid_argument for a ≤ 0, h ≤ 0, ℓ ≤ 0 or c ≤ 0.
NeedleBand needle_band_for(double radius, double element_size, double length, double c);

// The element size h of needle_band_for near a straight path (entry, unit axis, depth): the mean over
// the cells the path crosses of the edge of the cube of equal volume ((6V)^(1/3) for a tetrahedron —
// the edge of a Kuhn grid, on which the rule was measured — V^(1/3) for a grid cell).
double path_element_size(const CellLocator<3>& locator, const Vec<3>& entry, const Vec<3>& axis,
                         double depth);

// needle_band_for with the c measured for elements of degree 1 or 2 on the analytic antiplane and lateral
// shafts (docs/needle-model.md); default_coupling_radius is its R. Throws for another degree.
NeedleBand default_needle_band(double radius, double element_size, double length, unsigned degree);
double default_coupling_radius(double radius, double element_size, unsigned degree);

// The band of every station of a needle (BandCoupling and HapticNeedle): with coupling_radius > 0 one ring
// of that radius (the scenario's needle.coupling_radius), else default_needle_band. Throws as they do.
NeedleBand station_band(double radius, double coupling_radius, double element_size, double length,
                        unsigned degree);

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

}  // namespace vim::needle

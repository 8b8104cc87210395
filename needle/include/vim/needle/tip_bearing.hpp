// The end bearing of a 3D needle's tip (docs/needle-model.md, the tip bearing): before the tissue ahead
// of the tip is cut, the tip presses on it as a rigid flat punch of the needle's radius a. The model
// holds the mean axial displacement over a disk of radius R ≥ 1.1 a normal to the axis (rings of
// samples, a uniform mean over the disk, which carries force in the continuum where a point does not)
// through a compliance in series that makes the total that of the punch whatever the mesh:
//   κ_tip = C_punch − C_disk(R),   C_punch = (1 − ν²) / (2aE)                 (Sneddon 1965)
//   C_disk(R) = 16(1 − ν²) / (3π²RE)              on a free surface (Boussinesq, uniform disk load)
//             = (3 − 4ν) / (3π²G(1 − ν)R)         embedded in a full space (Kelvin, uniform disk load)
// C_disk is the mean over the disk of the displacement of a uniform load F = 1 over it (the mean of
// 1/|x − y| over two points of a disk is 16/(3πR)). The embedded tip uses the same punch: the pile base
// of Randolph & Wroth (1978, Géotechnique 28(4), 423–439). A disk at depth t below the free surface:
//   C_disk(R, t) = C_full + (C_surface − C_full) / (1 + t/t₀),   t₀ = K_m / (E (C_surface − C_full)),
// with K_m/(E t) the surface's part of Mindlin's (1936) displacement under a point load at depth t, at
// the load, K_m = (1 + ν)[(8(1 − ν)² − 3 + 4ν)/2 + (4(3 − 4ν) − 2)/8 + 3/4] / (8π(1 − ν)): exact at
// t = 0 and for t ≫ R, an assumed rational interpolation between. deal.II-free.
#pragma once

#include <cstddef>
#include <vim/needle/fem_types.hpp>

namespace vim::needle {

// The smallest disk radius over needle radius: C_disk(R) < C_punch needs R > 32a/(3π²) = 1.081a.
constexpr double kMinTipDiskRatio = 1.1;

// The axial compliance of a rigid flat punch of radius a on a half-space.
double punch_compliance(double radius, double youngs_modulus, double poisson_ratio);
// The mean displacement of a uniform unit load over a disk of radius R at `depth` below a half-space's
// free surface (0: on it; +∞: inside a full space).
double disk_compliance(double disk_radius, double youngs_modulus, double poisson_ratio, double depth);

// κ_tip = C_punch − C_disk(R, depth) (≥ 0): the compliance in series with the disk's mean.
double tip_bearing_compliance(double radius, double disk_radius, double youngs_modulus, double poisson_ratio,
                              double depth);

// The tip's row at `centre` (the tissue point ahead of the tip) for a needle of radius a along the unit
// `axis`: the axial component only (axes.col(2) = axis), the uniform mean over the disk of radius R
// (rings at the midpoints of equal radial parts, weight ∝ radius, samples spaced at most `spacing`,
// at least 8 per ring), compliance κ_tip above. Throws std::invalid_argument for a ≤ 0, R < 1.1a,
// spacing ≤ 0, a negative depth or a bad material.
PointConstraint<3> tip_bearing_constraint(const Vec<3>& centre, const Vec<3>& axis, double radius,
                                          double disk_radius, double spacing, double youngs_modulus,
                                          double poisson_ratio, double depth);

// The disks of the CLI and of the real-time needle alike (BandCoupling::tip_rows, HapticNeedle):
// radius max(R_band, 2a); samples spaced half the element size h (at most half the disk radius; h ≤ 0:
// half the disk radius).
double tip_disk_radius(double band_radius, double radius);
double tip_sample_spacing(double element_size, double disk_radius);
// A disk is in the tissue when at least half of its samples lie in the mesh.
inline bool tip_disk_in_tissue(std::size_t inside, std::size_t samples) { return inside >= samples / 2; }
// Where a straight path from `entry` along the unit `axis` enters the mesh: when the entry lies outside
// it or on its boundary (the point 10⁻⁶·length before it is outside), the arc length of the first point
// inside, in steps of length / 1000; −∞ when the entry lies inside (the disks are embedded).
double free_surface_along(const CellLocator<3>& locator, const Vec<3>& entry, const Vec<3>& axis,
                          double length);

}  // namespace vim::needle

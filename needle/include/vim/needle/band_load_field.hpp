// The displacement an infinite elastic body takes under a force spread over a needle band: the Kelvin
// solution integrated over the band's averaging region. The difference between the field of the force
// spread over the needle's own surface (radius a) and over the band (radius R) is the near field the
// mesh does not carry where it smears the needle's load over R (docs/needle-model.md, the field beyond
// the shaft's ends). deal.II-free.
#pragma once

#include <vim/needle/needle_band.hpp>

namespace vim::needle {

// The displacement at `x` of a body of Young's modulus E and Poisson ratio ν, unbounded, under the force
// `force` spread uniformly over the band's region around the axis through `centre` along the unit
// vector `axis`: the cross-section between inner_fraction·R and R (uniform per area; inner_fraction = 1:
// the cylinder surface of radius R) over the band's length ℓ. Integrated by Gauss–Legendre rules along
// the axis (on pieces halved until each is no longer than its distance from x) and across it, and the
// trapezoid rule around it: accurate to ~10⁻³ or better for points off the region; for a point inside a
// solid region (an integrable singularity) only roughly. Throws std::invalid_argument for a bad band or
// E ≤ 0, ν outside (−1, 0.5).
Vec<3> band_load_displacement(const NeedleBand& band, const Vec<3>& centre, const Vec<3>& axis,
                              const Vec<3>& force, const Vec<3>& x, double youngs_modulus,
                              double poisson_ratio);

// Kelvin's solution: the displacement at offset r ≠ 0 (0 at r = 0) from a point force f in an unbounded body,
// u = [(3 − 4ν) f + (r·f) r / |r|²] / (16 π G (1 − ν) |r|), G = E / (2(1 + ν)).
Vec<3> kelvin_displacement(const Vec<3>& r, const Vec<3>& force, double youngs_modulus, double poisson_ratio);

}  // namespace vim::needle

// Tests of the Kelvin field of a force spread over a needle band (vim/needle/band_load_field.hpp) against
// independent truth: the point force's closed form far from the band, and plane theory along a long
// band — there the field of the force on the needle's surface (radius a) minus its field spread over the
// band (radius R) is the 2D annulus solution: axially f ln(R/a) / (2πGℓ), laterally
// (3 − 4ν) f ln(R/a) / (8πG(1 − ν)ℓ) (the band compliances of needle_band.hpp), and for a solid band
// the logarithmic potential of a uniform disc at its centre, ln R − ½, in place of ln R.
#include <gtest/gtest.h>

#include <cmath>
#include <vim/needle/band_load_field.hpp>

using namespace vim;
using namespace vim::needle;

namespace {

constexpr double pi = 3.14159265358979323846;

NeedleBand ring(double radius, double length) {
  NeedleBand b;
  b.radius = std::min(radius, 0.5);
  b.coupling_radius = radius;
  b.length = length;
  return b;
}

}  // namespace

TEST(BandLoadField, KelvinAlongTheForceLineIsFOverFourPiGr) {
  const double E = 30.0, nu = 0.45, g = E / (2 * (1 + nu));
  const Vec<3> u = kelvin_displacement(Vec<3>(0, 0, 2.0), Vec<3>(0, 0, 5.0), E, nu);
  EXPECT_NEAR(u.z(), 5.0 / (4 * pi * g * 2.0), 1e-12);
  EXPECT_NEAR(u.head<2>().norm(), 0.0, 1e-15);
}

TEST(BandLoadField, FarFromTheBandItIsThePointForce) {
  const double E = 12.0, nu = 0.3;
  NeedleBand b = ring(2.0, 3.0);
  b.inner_fraction = 0.0;
  const Vec<3> centre(1, 2, 3), axis = Vec<3>(1, 1, 0).normalized(), f(0.3, -1.0, 2.0);
  const Vec<3> x = centre + Vec<3>(40.0, -25.0, 30.0);
  const Vec<3> u = band_load_displacement(b, centre, axis, f, x, E, nu);
  const Vec<3> point = kelvin_displacement(x - centre, f, E, nu);
  EXPECT_LT((u - point).norm(), 2e-3 * point.norm());
}

TEST(BandLoadField, SurfaceMinusBandOnALongBandIsTheAnnulusSolution) {
  const double E = 30.0, nu = 0.45, g = E / (2 * (1 + nu)), a = 0.5, R = 2.0, len = 400.0;
  const Vec<3> centre = Vec<3>::Zero(), axis(0, 0, 1), across(1, 0, 0);
  const NeedleBand needle = ring(a, len), band = ring(R, len);
  NeedleBand solid = band;
  solid.inner_fraction = 0.0;
  const auto difference = [&](const NeedleBand& b, const Vec<3>& f) {
    const Vec<3> on_surface = band_load_displacement(needle, centre, axis, f, centre, E, nu);
    const Vec<3> on_band = band_load_displacement(b, centre, axis, f, centre, E, nu);
    return Vec<3>(on_surface - on_band);
  };
  const double axial = std::log(R / a) / (2 * pi * g * len);
  const double lateral = (3 - 4 * nu) * std::log(R / a) / (8 * pi * g * (1 - nu) * len);
  EXPECT_NEAR(difference(band, axis).z() / axial, 1.0, 5e-4);
  EXPECT_NEAR(difference(band, across).x() / lateral, 1.0, 5e-4);
  // A uniform disc: its mean of ln ρ seen from the centre is ln R − ½.
  const double axial_solid = (std::log(R / a) - 0.5) / (2 * pi * g * len);
  EXPECT_NEAR(difference(solid, axis).z() / axial_solid, 1.0, 1e-3);
}

TEST(BandLoadField, RejectsABadBandOrMaterial) {
  const NeedleBand b = ring(1.0, 1.0);
  const Vec<3> o = Vec<3>::Zero(), z(0, 0, 1), x(0, 0, 5);
  EXPECT_THROW(band_load_displacement(b, o, z, z, x, 0.0, 0.3), std::invalid_argument);
  EXPECT_THROW(band_load_displacement(b, o, z, z, x, 1.0, 0.5), std::invalid_argument);
  NeedleBand flat = b;
  flat.length = 0.0;
  EXPECT_THROW(band_load_displacement(flat, o, z, z, x, 1.0, 0.3), std::invalid_argument);
}

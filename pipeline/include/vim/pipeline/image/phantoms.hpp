// Synthetic images with known geometry: the paper's Table I sphere phantom (§VI-C), its 2D
// phantoms of Figs. 2–4 (diamond) and Fig. 13 (two circles of different sizes, with the sizing
// field of Fig. 13(d)), a 2D two-inclusion elastogram and a 3D prostate elastography phantom.
// Used by the tests and by the vim-make-phantom executable.
#pragma once

#include <cstdint>
#include <string>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>

namespace vim::pipeline::phantoms {

// Table I: cube [0,3]³ of n³ voxels (spacing 3/n, voxel centres at (i+½)·3/n), sphere of radius 1
// at (1.5,1.5,1.5) with value 2.0 (centre inside iff |x−c| ≤ 1), background 1.0. n = 100 gives
// exactly 155,048 voxels inside.
OrientedImage<3> table1(int n = 100);
// The number of voxel centres inside the Table I sphere, counted in exact integer arithmetic.
long table1_sphere_voxels(int n = 100);

// Prostate vibro-elastography-like phantom, moduli in kPa, lengths in mm, identity direction,
// world origin at the gland centre. Image 60×50×50 mm with n voxels along x (n = 120: 0.5 mm).
// Gland: ellipsoid with semi-axes (20, 15, 17.5) mm, 60 kPa, in 15 kPa tissue. Lesion: sphere of
// radius 4 mm at prostate_lesion_centre, 150 kPa. Urethra: cylinder of radius 1.5 mm along x
// (the gland's long axis) through (·, 4, 0), 5 kPa, inside the gland only. The sharp label map is
// blurred once with [1 2 1]/4 along each axis and multiplied by (1 + 0.03·N(0,1)) noise from a
// mt19937_64 stream with `seed` (Box–Muller, so the values are identical on every platform).
struct ProstateGeometry {
  double gland_semi_axes[3] = {20.0, 15.0, 17.5};
  double lesion_centre[3] = {6.0, -5.0, 3.0};
  double lesion_radius = 4.0;
  double urethra_y = 4.0, urethra_z = 0.0, urethra_radius = 1.5;
  double tissue_kpa = 15.0, gland_kpa = 60.0, lesion_kpa = 150.0, urethra_kpa = 5.0;
  double noise = 0.03;
  double extent_mm[3] = {60.0, 50.0, 50.0};
};
OrientedImage<3> prostate(int n = 120, std::uint64_t seed = 1, const ProstateGeometry& g = {});
// The prostate phantom's labels (docs/labels.md) at a point (mm), and as an image on prostate()'s grid:
// the sharp label map behind its moduli, without blur or noise. The lesion wins over the urethra.
enum ProstateLabel { kProstateTissue = 1, kProstateGland = 2, kProstateLesion = 3, kProstateUrethra = 4 };
int prostate_label(const Eigen::Vector3d& p, const ProstateGeometry& g = {});
OrientedImage<3> prostate_labels(int n = 120, const ProstateGeometry& g = {});

// Paper Figs. 2–4: square [0,100]² mm, n×n pixels, background 1.0, diamond |x−50|+|y−50| ≤ 30 of 2.0.
OrientedImage<2> diamond(int n = 100);
// Paper Fig. 13(a): square [0,100]² mm, background 1.0; a large circle (r = 20 at (28,70)) and a
// small one (r = 5 at the centre (50,50)), both 2.0.
OrientedImage<2> two_circles(int n = 200);
// Paper Fig. 13(d): sizing (density) field for two_circles, 1 + 9·exp(−|x−c|²/(2·10²)) around the
// small circle's centre.
OrientedImage<2> two_circles_sizing(int n = 200);
// 2D elastogram: 60×60 mm, n×n pixels, 15 kPa background, inclusion of 60 kPa (r = 10 mm at
// (−12,−8)) and of 150 kPa (r = 5 mm at (14,10)); origin chosen so the image centre is (0,0).
OrientedImage<2> two_inclusions(int n = 120);

// Names accepted by make(), in the order vim-make-phantom lists them.
const std::vector<std::string>& names();
// One-line description of a phantom (for --help).
std::string description(const std::string& name);

}  // namespace vim::pipeline::phantoms

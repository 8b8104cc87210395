// Phantoms (pipeline/include/vim/pipeline/image/phantoms.hpp): geometry recomputed here in floating
// point from the stated definitions, the paper's Table I count, the prostate phantom's values at
// known anatomical points, and the vim-make-phantom executable.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vim/pipeline/image/phantoms.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;

TEST(Table1Phantom, SphereHasExactly155048VoxelCentres) {
  const auto p = phantoms::table1();
  const Image<3>& im = p.image;
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(im.size[a], 100);
    EXPECT_DOUBLE_EQ(im.spacing[a], 0.03);
    EXPECT_DOUBLE_EQ(im.origin[a], 0.015);
    EXPECT_NEAR(im.box_min()[a], 0.0, 1e-15);
    EXPECT_NEAR(im.box_max()[a], 3.0, 1e-12);
  }
  // Independent count: voxel centres (i+½)·0.03 with |x − (1.5,1.5,1.5)| ≤ 1, in doubles.
  long inside = 0, value2 = 0, mismatched = 0;
  for (long k = 0; k < 100; ++k)
    for (long j = 0; j < 100; ++j)
      for (long i = 0; i < 100; ++i) {
        const double x = (i + 0.5) * 0.03 - 1.5, y = (j + 0.5) * 0.03 - 1.5, z = (k + 0.5) * 0.03 - 1.5;
        const bool in = x * x + y * y + z * z <= 1.0;
        const float v = im.at({{i, j, k}});
        inside += in;
        value2 += v == 2.0f;
        mismatched += (in ? v != 2.0f : v != 1.0f);
      }
  EXPECT_EQ(inside, 155048);
  EXPECT_EQ(value2, 155048);
  EXPECT_EQ(mismatched, 0);
  EXPECT_EQ(phantoms::table1_sphere_voxels(100), 155048);
}

TEST(Table1Phantom, OtherResolutionsKeepTheCube) {
  const auto p = phantoms::table1(40);
  EXPECT_EQ(p.image.size[2], 40);
  EXPECT_DOUBLE_EQ(p.image.spacing[0], 3.0 / 40);
  EXPECT_NEAR(p.image.box_max()[1], 3.0, 1e-12);
  long twos = 0;
  for (float v : p.image.data) twos += v == 2.0f;
  EXPECT_EQ(twos, phantoms::table1_sphere_voxels(40));
  // Volume check: (count × voxel volume) approaches 4π/3.
  EXPECT_NEAR(twos * std::pow(3.0 / 40, 3), 4.0 * M_PI / 3.0, 0.05);
}

TEST(ProstatePhantom, GeometryAndValuesAtKnownPoints) {
  const auto p = phantoms::prostate();  // 0.5 mm voxels
  const Image<3>& im = p.image;
  EXPECT_EQ(im.size[0], 120);
  EXPECT_EQ(im.size[1], 100);
  EXPECT_EQ(im.size[2], 100);
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(im.spacing[a], 0.5);
  EXPECT_TRUE(p.direction.isIdentity(0.0));
  const double extent[3] = {60, 50, 50};
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(im.box_min()[a], -extent[a] / 2, 1e-12);  // gland centre (0,0,0) = image centre
    EXPECT_NEAR(im.box_max()[a], extent[a] / 2, 1e-12);
  }
  // Value at the voxel nearest a world point (mm).
  auto at = [&](double x, double y, double z) {
    const auto c = im.continuous_index(Eigen::Vector3d(x, y, z));
    return im.at({{std::lround(c[0]), std::lround(c[1]), std::lround(c[2])}});
  };
  // 3 % noise: ±5 σ.
  EXPECT_NEAR(at(-28, -23, -23), 15.0, 15.0 * 0.15);  // tissue corner
  EXPECT_NEAR(at(25, 0, 0), 15.0, 15.0 * 0.15);       // outside the gland along x (semi-axis 20)
  EXPECT_NEAR(at(-10, -3, -5), 60.0, 60.0 * 0.15);    // gland
  EXPECT_NEAR(at(0, -10, 0), 60.0, 60.0 * 0.15);      // gland, below the urethra
  EXPECT_NEAR(at(6, -5, 3), 150.0, 150.0 * 0.15);     // lesion centre
  EXPECT_NEAR(at(6, -5, 5.5), 150.0, 150.0 * 0.15);   // inside the 4 mm lesion radius
  EXPECT_NEAR(at(-8, 4, 0), 5.0, 5.0 * 0.15);         // urethra along the long (x) axis
  EXPECT_NEAR(at(15, 4, 0), 5.0, 5.0 * 0.15);
  EXPECT_NEAR(at(0, 14, 0), 60.0, 60.0 * 0.15);  // gland edge along y is at 15 mm
  EXPECT_NEAR(at(0, 17, 0), 15.0, 15.0 * 0.15);
  // Overall: everything positive and within the physical range.
  float lo = 1e30f, hi = -1e30f;
  for (float v : im.data) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_GT(lo, 3.0f);
  EXPECT_LT(hi, 200.0f);
  // Mild noise: the standard deviation of the tissue in a corner block is ≈ 3 % of 15 kPa.
  double s = 0, q = 0;
  int n = 0;
  for (long k = 0; k < 10; ++k)
    for (long j = 0; j < 10; ++j)
      for (long i = 0; i < 10; ++i, ++n) {
        const double v = im.at({{i, j, k}});
        s += v;
        q += v * v;
      }
  const double sd = std::sqrt(q / n - (s / n) * (s / n));
  EXPECT_GT(sd, 0.01 * 15);
  EXPECT_LT(sd, 0.05 * 15);
}

TEST(ProstatePhantom, SeedIsReproducible) {
  const auto a = phantoms::prostate(40, 7), b = phantoms::prostate(40, 7), c = phantoms::prostate(40, 8);
  EXPECT_EQ(a.image.data, b.image.data);
  EXPECT_NE(a.image.data, c.image.data);
}

// The label image of the prostate phantom: each label's volume against its shape's closed form (the
// ellipsoid 4/3·π·20·15·17.5, the lesion ball 4/3·π·4³, the urethra a cylinder of radius 1.5 through
// the gland minus the lesion, which it misses), within the voxelisation's few percent at 0.5 mm.
TEST(ProstatePhantom, LabelVolumesMatchTheShapes) {
  const auto p = phantoms::prostate_labels();
  const auto& im = p.image;
  const auto values = phantoms::prostate();
  ASSERT_EQ(im.size, values.image.size);
  std::map<int, double> volume;
  for (float v : im.data) volume[static_cast<int>(v)] += 0.125;
  ASSERT_EQ(volume.size(), 4u);
  const double gland = 4.0 / 3.0 * M_PI * 20.0 * 15.0 * 17.5, lesion = 4.0 / 3.0 * M_PI * 64.0;
  // The urethra y = 4, z = 0 crosses the ellipsoid over |x| ≤ 20·sqrt(1 − (4/15)²); its cross-section is
  // the voxel centres (y, z) = (−24.75 + 0.5 j, −24.75 + 0.5 k) within 1.5 mm of (4, 0), counted here (a
  // radius of 3 voxels holds 32 centres, 13% over π·1.5²: the lattice, not an error).
  long section = 0;
  for (int j = 0; j < 100; ++j)
    for (int k = 0; k < 100; ++k) {
      const double y = -24.75 + 0.5 * j - 4.0, z = -24.75 + 0.5 * k;
      section += y * y + z * z <= 1.5 * 1.5;
    }
  const double urethra = 0.25 * static_cast<double>(section) * 2.0 * 20.0 * std::sqrt(1.0 - 16.0 / 225.0);
  EXPECT_NEAR(volume[phantoms::kProstateLesion], lesion, 0.05 * lesion);
  EXPECT_NEAR(volume[phantoms::kProstateUrethra], urethra, 0.05 * urethra);
  EXPECT_NEAR(volume[phantoms::kProstateGland] + volume[phantoms::kProstateLesion] +
                  volume[phantoms::kProstateUrethra],
              gland, 0.02 * gland);
  EXPECT_NEAR(volume[phantoms::kProstateTissue], 60.0 * 50.0 * 50.0 - gland, 0.02 * gland);
}

TEST(Phantoms2D, DiamondAndCircles) {
  const auto d = phantoms::diamond(100);  // 1 mm pixels over [0,100]²
  auto val = [](const OrientedImage<2>& im, double x, double y) {
    const auto c = im.image.continuous_index(Eigen::Vector2d(x, y));
    return im.image.at({{std::lround(c[0]), std::lround(c[1])}});
  };
  EXPECT_EQ(val(d, 50.5, 50.5), 2.0f);
  EXPECT_EQ(val(d, 78.5, 50.5), 2.0f);  // |28|+|0.5| ≤ 30
  EXPECT_EQ(val(d, 70.5, 70.5), 1.0f);  // |20|+|20| > 30
  EXPECT_EQ(val(d, 5.5, 5.5), 1.0f);
  const auto t = phantoms::two_circles(200);
  EXPECT_EQ(val(t, 50.25, 50.25), 2.0f);  // small circle
  EXPECT_EQ(val(t, 56.25, 50.25), 1.0f);  // just outside r = 5
  EXPECT_EQ(val(t, 28.25, 70.25), 2.0f);  // big circle
  EXPECT_EQ(val(t, 28.25, 89.25), 2.0f);
  EXPECT_EQ(val(t, 28.25, 91.25), 1.0f);
  // Two features of different sizes: pixel areas ≈ π·20² and π·5² (mm², 0.5 mm pixels).
  long twos = 0;
  for (float v : t.image.data) twos += v == 2.0f;
  EXPECT_NEAR(twos * 0.25, M_PI * (400 + 25), 10.0);
  const auto two = phantoms::two_inclusions(120);
  EXPECT_NEAR(two.image.box_min()[0], -30.0, 1e-12);
  EXPECT_EQ(val(two, 14.25, 10.25), 150.0f);
  EXPECT_EQ(val(two, -12.25, -8.25), 60.0f);
  EXPECT_EQ(val(two, 25.25, -25.25), 15.0f);
}

TEST(MakePhantomExe, WritesReadableImagesAndRejectsBadKinds) {
  vim::test::TempDir dir("mkph");
  const auto ok =
      vim::test::run_command(VIM_PHANTOM_EXE, "table1 " + vim::test::quote(dir / "t.mha") + " --size 20");
  ASSERT_EQ(ok.code, 0) << ok.err;
  const auto im = read_image<3>(dir / "t.mha");
  EXPECT_EQ(im.image.size[0], 20);
  EXPECT_EQ(im.image.data, phantoms::table1(20).image.data);
  const auto bad = vim::test::run_command(VIM_PHANTOM_EXE, "banana " + vim::test::quote(dir / "b.mha"));
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("banana"), std::string::npos) << bad.err;
  const auto help = vim::test::run_command(VIM_PHANTOM_EXE, "--help");
  EXPECT_EQ(help.code, 0);
  for (const auto& n : phantoms::names()) EXPECT_NE(help.out.find(n), std::string::npos) << n;
}

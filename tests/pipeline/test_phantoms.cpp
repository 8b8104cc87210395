// Phantoms (pipeline/include/vim/pipeline/image/phantoms.hpp): geometry recomputed here in floating
// point from the stated definitions, the paper's Table I count, the prostate phantom's values at
// known anatomical points, and the vim-make-phantom executable.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
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

// Truth: the stated anatomy recomputed here at known points and as volumes (ellipsoid, sphere), and the
// elastogram: where a voxel's 3×3×3 neighbourhood holds one label, the blur leaves that label's modulus
// and only the 3 % noise changes it.
TEST(ProstatePhantom, LabelMapFollowsTheStatedAnatomyAndTheElastogram) {
  const auto labels = phantoms::prostate_labels(60);  // 1 mm voxels
  const auto moduli = phantoms::prostate(60);
  const Image<3>& im = labels.image;
  ASSERT_EQ(im.size, moduli.image.size);
  ASSERT_EQ(im.origin, moduli.image.origin);
  auto at = [&](double x, double y, double z) {
    const auto c = im.continuous_index(Eigen::Vector3d(x, y, z));
    return static_cast<int>(im.at({{std::lround(c[0]), std::lround(c[1]), std::lround(c[2])}}));
  };
  EXPECT_EQ(at(-28, -23, -23), 1);   // tissue corner
  EXPECT_EQ(at(-10, -3, -5), 2);     // gland
  EXPECT_EQ(at(6, -5, 3), 3);        // lesion centre
  EXPECT_EQ(at(-8, 4, 0), 4);        // urethra
  EXPECT_EQ(at(0, -22 + 7, 10), 1);  // beside the rectum wall: |(7, 10)| > 8
  EXPECT_EQ(at(10, -22 + 7, 0), 5);  // rectum wall, 7 mm from the probe's axis
  EXPECT_EQ(at(-25, -22, 0), 7);     // the probe
  EXPECT_EQ(at(12, 21, -20), 6);     // pubic bone, along z
  EXPECT_EQ(at(12, 16, 0), 1);       // between the gland and the bone
  std::vector<long> count(8, 0);
  for (float v : im.data) {
    ASSERT_EQ(v, std::round(v));
    ASSERT_GE(v, 1.0f);
    ASSERT_LE(v, 7.0f);
    ++count[static_cast<std::size_t>(v)];
  }
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(double(count[2] + count[3] + count[4]), 4.0 / 3.0 * pi * 20 * 15 * 17.5,
              0.01 * 4.0 / 3.0 * pi * 20 * 15 * 17.5);
  EXPECT_NEAR(double(count[3]), 4.0 / 3.0 * pi * 64, 0.08 * 4.0 / 3.0 * pi * 64);
  // The bone: a cylinder of radius 3 along the 50 mm z extent (32 voxel centres of a 1 mm lattice at
  // half-integer offsets lie in its 28.3 mm² disk).
  EXPECT_NEAR(double(count[6]), pi * 9 * 50, 0.15 * pi * 9 * 50);
  const double kpa[8] = {0, 15, 60, 150, 5, 15, 15, 15};
  long interior = 0;
  for (long k = 1; k + 1 < im.size[2]; ++k)
    for (long j = 1; j + 1 < im.size[1]; ++j)
      for (long i = 1; i + 1 < im.size[0]; ++i) {
        const float l = im.at({{i, j, k}});
        bool same = true;
        for (long c = -1; c <= 1 && same; ++c)
          for (long b = -1; b <= 1 && same; ++b)
            for (long a = -1; a <= 1 && same; ++a) same = im.at({{i + a, j + b, k + c}}) == l;
        if (!same) continue;
        ++interior;
        EXPECT_NEAR(moduli.image.at({{i, j, k}}), kpa[static_cast<int>(l)], 0.15 * kpa[static_cast<int>(l)]);
      }
  EXPECT_GT(interior, im.voxel_count() / 2);
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
  ASSERT_EQ(volume.size(), 7u);
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
  EXPECT_NEAR(volume[phantoms::kLesion], lesion, 0.05 * lesion);
  EXPECT_NEAR(volume[phantoms::kUrethra], urethra, 0.05 * urethra);
  EXPECT_NEAR(volume[phantoms::kGland] + volume[phantoms::kLesion] + volume[phantoms::kUrethra], gland,
              0.02 * gland);
  double outside = 0.0;  // every label outside the gland's ellipsoid
  for (int l : {phantoms::kTissue, phantoms::kRectumWall, phantoms::kPubicBone, phantoms::kProbe})
    outside += volume[l];
  EXPECT_NEAR(outside, 60.0 * 50.0 * 50.0 - gland, 0.02 * gland);
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
  const auto labels = vim::test::run_command(VIM_PHANTOM_EXE, "prostate " + vim::test::quote(dir / "p.mha") +
                                                                  " --size 24 --labels " +
                                                                  vim::test::quote(dir / "p_labels.mha"));
  ASSERT_EQ(labels.code, 0) << labels.err;
  EXPECT_EQ(read_image<3>(dir / "p_labels.mha").image.data, phantoms::prostate_labels(24).image.data);
  EXPECT_EQ(read_image<3>(dir / "p.mha").image.data, phantoms::prostate(24).image.data);
  EXPECT_NE(vim::test::slurp(dir / "p_labels.mha").find("ElementType = MET_SHORT"), std::string::npos);
  const auto no_labels =
      vim::test::run_command(VIM_PHANTOM_EXE, "table1 " + vim::test::quote(dir / "t2.mha") + " --labels " +
                                                  vim::test::quote(dir / "l.mha"));
  EXPECT_EQ(no_labels.code, 2);
  EXPECT_NE(no_labels.err.find("--labels"), std::string::npos) << no_labels.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "t2.mha"));
  const auto help = vim::test::run_command(VIM_PHANTOM_EXE, "--help");
  EXPECT_EQ(help.code, 0);
  for (const auto& n : phantoms::names()) EXPECT_NE(help.out.find(n), std::string::npos) << n;
}

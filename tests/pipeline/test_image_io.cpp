// Image IO (pipeline/include/vim/pipeline/image/image_io.hpp): round trips through .mha/.nrrd/.nii.gz with
// anisotropic spacing, a non-zero origin and an oblique direction in 2D and 3D, and integer files
// written by hand (independent of our writer) read back as float with their geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <vim/pipeline/image/image_io.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;

namespace {

Eigen::Matrix3d oblique3() {
  // Rotation about (1,2,3)/|.| by 0.7 rad, non-symmetric so a transposition would show.
  const Eigen::Vector3d k = Eigen::Vector3d(1, 2, 3).normalized();
  Eigen::Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  const double t = 0.7;
  return Eigen::Matrix3d::Identity() + std::sin(t) * K + (1 - std::cos(t)) * K * K;
}

Eigen::Matrix2d oblique2() {
  const double t = 0.4;
  Eigen::Matrix2d r;
  r << std::cos(t), -std::sin(t), std::sin(t), std::cos(t);
  return r;
}

template <int dim>
OrientedImage<dim> test_image() {
  OrientedImage<dim> im;
  std::array<long, dim> size{};
  std::array<double, dim> spacing{}, origin{};
  for (int a = 0; a < dim; ++a) {
    size[a] = 5 + 2 * a;           // 5, 7, 9
    spacing[a] = 0.5 + 0.75 * a;   // anisotropic
    origin[a] = -12.5 + 3.25 * a;  // non-zero
  }
  im.image = Image<dim>(size, spacing, origin);
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k)
    im.image.data[k] = static_cast<float>(std::sin(0.37 * k) * 100.0 + 0.001 * k);
  if constexpr (dim == 3)
    im.direction = oblique3();
  else
    im.direction = oblique2();
  return im;
}

template <int dim>
void expect_same(const OrientedImage<dim>& a, const OrientedImage<dim>& b, double geometry_tol) {
  for (int d = 0; d < dim; ++d) {
    EXPECT_EQ(a.image.size[d], b.image.size[d]);
    EXPECT_NEAR(a.image.spacing[d], b.image.spacing[d], geometry_tol * std::abs(a.image.spacing[d]));
    EXPECT_NEAR(a.image.origin[d], b.image.origin[d], geometry_tol * 20.0);
    for (int e = 0; e < dim; ++e)
      EXPECT_NEAR(a.direction(d, e), b.direction(d, e), geometry_tol) << d << "," << e;
  }
  ASSERT_EQ(a.image.data.size(), b.image.data.size());
  for (std::size_t k = 0; k < a.image.data.size(); ++k)
    ASSERT_EQ(a.image.data[k], b.image.data[k]) << "voxel " << k;
}

}  // namespace

class ImageRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(ImageRoundTrip, PreservesValuesAndGeometry3D) {
  vim::test::TempDir dir("io3");
  const auto in = test_image<3>();
  const std::string path = dir / ("image" + GetParam());
  write_image(in, path);
  EXPECT_EQ(image_dimension(path), 3);
  // NIfTI stores the geometry in float32: allow single precision there.
  expect_same(in, read_image<3>(path), GetParam().find(".nii") != std::string::npos ? 2e-6 : 1e-12);
  EXPECT_EQ(vim::test::count_files(dir.path), 1) << "temporary file left behind";
}

TEST_P(ImageRoundTrip, PreservesValuesAndGeometry2D) {
  vim::test::TempDir dir("io2");
  const auto in = test_image<2>();
  const std::string path = dir / ("image" + GetParam());
  write_image(in, path);
  EXPECT_EQ(image_dimension(path), 2);
  expect_same(in, read_image<2>(path), GetParam().find(".nii") != std::string::npos ? 2e-6 : 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Formats, ImageRoundTrip, ::testing::Values(".mha", ".nrrd", ".nii.gz"),
                         [](const auto& info) {
                           std::string s = info.param.substr(1);
                           for (char& c : s)
                             if (c == '.') c = '_';
                           return s;
                         });

// A NRRD written by hand: uint8 voxels, 3D, oblique "space directions" (columns = axis direction
// × spacing), origin. The reader must give float values, spacing = column norms, direction =
// normalised columns, and world point of index i = origin + D·(i ⊙ spacing).
TEST(ImageRead, HandWrittenNrrdUint8Oblique) {
  vim::test::TempDir dir("nrrd");
  const Eigen::Matrix3d R = oblique3();
  const double sp[3] = {0.4, 0.9, 2.5};
  const long n[3] = {3, 4, 2};
  const std::string path = dir / "u8.nrrd";
  {
    std::ofstream f(path, std::ios::binary);
    f.precision(17);
    f << "NRRD0004\ntype: uint8\ndimension: 3\nspace: left-posterior-superior\nsizes: 3 4 2\n"
      << "space directions:";
    for (int a = 0; a < 3; ++a)
      f << " (" << R(0, a) * sp[a] << "," << R(1, a) * sp[a] << "," << R(2, a) * sp[a] << ")";
    f << "\nkinds: domain domain domain\nendian: little\nencoding: raw\nspace origin: (10.5,-3.25,7)\n\n";
    for (int k = 0; k < 24; ++k) f.put(static_cast<char>(static_cast<std::uint8_t>(10 * k + 3)));
  }
  const auto im = read_image<3>(path);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(im.image.size[a], n[a]);
    EXPECT_NEAR(im.image.spacing[a], sp[a], 1e-12);
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(im.direction(a, b), R(a, b), 1e-12);
  }
  EXPECT_DOUBLE_EQ(im.image.origin[0], 10.5);
  EXPECT_DOUBLE_EQ(im.image.origin[1], -3.25);
  EXPECT_DOUBLE_EQ(im.image.origin[2], 7.0);
  for (int k = 0; k < 24; ++k) EXPECT_EQ(im.image.data[k], static_cast<float>(10 * k + 3));
  // Index (2,3,1) → world = origin + Σ_a i_a · spacing_a · column_a of the file.
  const Eigen::Vector3d expected =
      Eigen::Vector3d(10.5, -3.25, 7) + 2 * sp[0] * R.col(0) + 3 * sp[1] * R.col(1) + 1 * sp[2] * R.col(2);
  const Eigen::Vector3d got = im.to_world(im.image.point_of({{2, 3, 1}}));
  EXPECT_NEAR((got - expected).norm(), 0.0, 1e-12);
}

// A MetaImage written by hand: int16 (negative values too), 2D, anisotropic, offset.
TEST(ImageRead, HandWrittenMetaImageInt16) {
  vim::test::TempDir dir("mha");
  const std::string path = dir / "s16.mha";
  {
    std::ofstream f(path, std::ios::binary);
    f << "ObjectType = Image\nNDims = 2\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << "Offset = -4.5 2.25\nElementSpacing = 0.3 1.7\nDimSize = 4 3\nElementType = MET_SHORT\n"
      << "ElementDataFile = LOCAL\n";
    for (int k = 0; k < 12; ++k) {
      const std::int16_t v = static_cast<std::int16_t>(-3000 + 577 * k);
      f.write(reinterpret_cast<const char*>(&v), 2);
    }
  }
  EXPECT_EQ(image_dimension(path), 2);
  const auto im = read_image<2>(path);
  EXPECT_EQ(im.image.size[0], 4);
  EXPECT_EQ(im.image.size[1], 3);
  EXPECT_DOUBLE_EQ(im.image.spacing[0], 0.3);
  EXPECT_DOUBLE_EQ(im.image.spacing[1], 1.7);
  EXPECT_DOUBLE_EQ(im.image.origin[0], -4.5);
  EXPECT_DOUBLE_EQ(im.image.origin[1], 2.25);
  EXPECT_TRUE(im.direction.isIdentity(0.0));
  for (int k = 0; k < 12; ++k) EXPECT_EQ(im.image.data[k], static_cast<float>(-3000 + 577 * k)) << k;
  // Row-major layout: voxel (i=1, j=2) is element 1 + 4·2 of the file.
  EXPECT_EQ(im.image.at({{1, 2}}), static_cast<float>(-3000 + 577 * 9));
}

// A MetaImage written by hand with an oblique TransformMatrix (uint8, 3D): the file lists the
// direction column by column (the MetaIO convention ITK uses).
TEST(ImageRead, HandWrittenMetaImageObliqueDirection) {
  vim::test::TempDir dir("mha3");
  const Eigen::Matrix3d R = oblique3();
  const std::string path = dir / "u8.mha";
  {
    std::ofstream f(path, std::ios::binary);
    f.precision(17);
    f << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix "
         "=";
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) f << " " << R(b, a);
    f << "\nOffset = 1 2 3\nElementSpacing = 0.5 0.5 2\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
      << "ElementDataFile = LOCAL\n";
    for (int k = 0; k < 8; ++k) f.put(static_cast<char>(200 + k));
  }
  const auto im = read_image<3>(path);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(im.direction(a, b), R(a, b), 1e-12);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(im.image.data[k], static_cast<float>(200 + k));
  // Same file through our writer: identical direction (writer and reader agree with the file).
  write_image(im, dir / "again.mha");
  const auto again = read_image<3>(dir / "again.mha");
  EXPECT_TRUE(again.direction.isApprox(im.direction, 1e-14));
}

TEST(ImageRead, ErrorsNameTheFileAndProblem) {
  vim::test::TempDir dir("ioerr");
  auto message = [](auto f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no InputError");
  };
  const std::string missing = dir / "nope.mha";
  EXPECT_NE(message([&] { read_image<3>(missing); }).find(missing + ": file does not exist"),
            std::string::npos);
  // 3D file read as 2D names both dimensions.
  write_image(test_image<3>(), dir / "three.mha");
  const std::string m = message([&] { read_image<2>(dir / "three.mha"); });
  EXPECT_NE(m.find("3 dimensions; expected 2"), std::string::npos) << m;
  // NaN voxels: count and first index.
  auto im = test_image<2>();
  im.image.at({{3, 2}}) = std::nanf("");
  im.image.at({{4, 5}}) = std::numeric_limits<float>::infinity();
  write_image(im, dir / "nan.nrrd");
  const std::string n = message([&] { read_image<2>(dir / "nan.nrrd"); });
  EXPECT_NE(n.find("2 voxels are NaN or Inf (first at index (3,2))"), std::string::npos) << n;
}

// in_frame_of: a second image with the same (oblique) direction but another origin, resampled into the
// first image's frame by moving its origin. Each image's frame turns about its own origin, so using the
// second image's frame coordinates directly would sample it (Dᵀ − I)(o₁ − o₂) away from the right place
// (a --sizing image on a rotated elastogram). Checked against to_world / to_frame point by point, and
// on the voxel that a world point falls in.
TEST(ImageFrames, InFrameOfMapsThroughWorldCoordinates) {
  OrientedImage<3> ref, other;
  ref.image = Image<3>({{10, 10, 4}}, {{1, 1, 2}}, {{0, 0, 0}}, 1.0f);
  ref.direction = oblique3();
  other.image = Image<3>({{40, 40, 8}}, {{1, 1, 2}}, {{20, -20, 3}}, 0.0f);
  other.direction = oblique3();
  for (std::size_t k = 0; k < other.image.data.size(); ++k) other.image.data[k] = static_cast<float>(k);
  const Image<3> moved = in_frame_of(ref, other);
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(3.3, -1.2, 5.0), Eigen::Vector3d(9, 9, 6)}) {
    const Eigen::Vector3d q =
        other.to_frame(ref.to_world(p));  // other's own frame point of the same world point
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(q[a] - other.image.origin[a], p[a] - moved.origin[a], 1e-9) << a;
  }
  // Same direction and origin: nothing moves. Different directions: refused.
  OrientedImage<3> same = other;
  same.image.origin = ref.image.origin;
  const Image<3> unmoved = in_frame_of(ref, same);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(unmoved.origin[a], ref.image.origin[a], 1e-12);
  same.direction = Eigen::Matrix3d::Identity();
  EXPECT_THROW(in_frame_of(ref, same), std::invalid_argument);
  // With the identity direction the frames are world-aligned and the origin stays.
  ref.direction = other.direction = Eigen::Matrix3d::Identity();
  const Image<3> plain = in_frame_of(ref, other);
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(plain.origin[a], other.image.origin[a]);
}

// Bad input images through the real vim-pipeline executable: each case must exit with 1, print
// exactly one `vim-pipeline: error:` line naming the file and the problem, and leave no file in
// --out (the folder is not created, or is empty).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;

namespace {

struct BadImage {
  std::string name;     // test name and file stem
  std::string file;     // file name inside the temp folder
  std::string problem;  // text the message must contain
  std::function<void(const std::string& path)> make;
  std::string extra_args = "";
};
// Printed by GoogleTest (and so by CTest's test list) for the parameter: the file and the problem,
// instead of the struct's bytes.
void PrintTo(const BadImage& c, std::ostream* os) { *os << c.file << ": " << c.problem; }

// A MetaImage with the given header lines and `bytes` bytes of data.
std::function<void(const std::string&)> mha(const std::string& header, std::size_t bytes) {
  return [=](const std::string& path) {
    std::ofstream f(path, std::ios::binary);
    f << "ObjectType = Image\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << header << "ElementDataFile = LOCAL\n";
    for (std::size_t i = 0; i < bytes; ++i) f.put('\x01');
  };
}

std::function<void(const std::string&)> image_with(float value, long i, long j, long k) {
  return [=](const std::string& path) {
    auto im = phantoms::table1(10);
    im.image.at({{i, j, k}}) = value;
    im.image.at({{9, 9, 9}}) = value;
    write_image(im, path);
  };
}

std::vector<BadImage> cases() {
  return {
      {"Missing", "missing.mha", "file does not exist", [](const std::string&) {}},
      {"EmptyFile", "empty.mha", "file is empty", [](const std::string& p) { std::ofstream f(p); }},
      {"Directory", "dir.mha", "is a directory",
       [](const std::string& p) { std::filesystem::create_directory(p); }},
      {"NotAnImage", "text.mha", "not a readable image",
       [](const std::string& p) { std::ofstream(p) << "hello, I am not an image\n"; }},
      {"UnknownExtension", "data.xyz", "not a readable image",
       [](const std::string& p) { std::ofstream(p) << "1 2 3 4\n"; }},
      {"Truncated", "trunc.mha", "cannot read the voxel data",
       mha("NDims = 3\nDimSize = 10 10 10\nElementSpacing = 1 1 1\nElementType = MET_FLOAT\n", 1000)},
      {"VectorPixels", "rgb.mha", "3 components",
       mha("NDims = 2\nDimSize = 4 4\nElementSpacing = 1 1\nElementNumberOfChannels = 3\nElementType = "
           "MET_UCHAR\n",
           48)},
      {"FourDimensions", "four.mha", "4 dimensions; expected 2 or 3",
       mha("NDims = 4\nDimSize = 2 2 2 2\nElementSpacing = 1 1 1 1\nElementType = MET_UCHAR\n", 16)},
      {"OneDimension", "one.mha", "1 dimensions; expected 2 or 3",
       mha("NDims = 1\nDimSize = 8\nElementSpacing = 1\nElementType = MET_UCHAR\n", 8)},
      {"ZeroSpacing", "zsp.mha", "spacing along axis 1 is 0",
       mha("NDims = 3\nDimSize = 4 4 4\nElementSpacing = 1 0 1\nElementType = MET_UCHAR\n", 64)},
      {"NegativeSpacing", "nsp.nrrd", "spacing along axis 0 is -0.5",
       [](const std::string& p) {
         std::ofstream f(p, std::ios::binary);
         f << "NRRD0004\ntype: uint8\ndimension: 2\nsizes: 4 4\nspacings: -0.5 1\nencoding: raw\n\n";
         for (int i = 0; i < 16; ++i) f.put('\x02');
       }},
      {"HugeHeader", "huge.mha", "header declares",
       mha("NDims = 3\nDimSize = 100000 100000 100000\nElementSpacing = 1 1 1\nElementType = MET_FLOAT\n",
           64)},
      {"NaNVoxels", "nan.mha", "2 voxels are NaN or Inf (first at index (3,4,5))",
       image_with(std::nanf(""), 3, 4, 5)},
      {"InfVoxels", "inf.nrrd", "2 voxels are NaN or Inf (first at index (0,0,1))",
       image_with(-std::numeric_limits<float>::infinity(), 0, 0, 1)},
      {"OneVoxelThick", "thin.mha", "1 voxel thick along axis 2",
       [](const std::string& p) {
         OrientedImage<3> im;
         im.image = Image<3>({{8, 8, 1}}, {{1, 1, 1}}, {{0, 0, 0}}, 5.0f);
         write_image(im, p);
       }},
      {"NonOrthonormalDirection", "skew.mha", "direction matrix is not orthonormal",
       mha("NDims = 3\nTransformMatrix = 2 0 0 0 1 0 0 0 1\nDimSize = 4 4 4\nElementSpacing = 1 1 1\n"
           "ElementType = MET_UCHAR\n",
           64)},
      {"SizingMissing", "ok.mha", "nosizing.mha: file does not exist",
       [](const std::string& p) { write_image(phantoms::table1(10), p); }, "--sizing nosizing.mha"},
  };
}

}  // namespace

class BadImages : public ::testing::TestWithParam<BadImage> {};

TEST_P(BadImages, OneLineNamingFileExitOneNothingWritten) {
  const BadImage& c = GetParam();
  vim::test::TempDir dir("bad_" + c.name);
  const std::string path = dir / c.file;
  c.make(path);
  const auto out = dir.path / "out";
  std::string extra = c.extra_args;
  if (!extra.empty()) {  // relative file names in extra args live in the temp folder
    const auto sp = extra.find(' ');
    extra = extra.substr(0, sp + 1) + vim::test::quote(dir / extra.substr(sp + 1));
  }
  const auto r =
      vim::test::run_pipeline(vim::test::quote(path) + " " + extra + " --nodes 27 --max-iterations 1 --out " +
                              vim::test::quote(out.string()));
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
  EXPECT_EQ(vim::test::count_lines(r.err), 1) << r.err;
  const std::string named = c.name == "SizingMissing" ? "nosizing.mha" : c.file;
  EXPECT_NE(r.err.find(named), std::string::npos) << "message does not name the file: " << r.err;
  EXPECT_NE(r.err.find(c.problem), std::string::npos) << "expected '" << c.problem << "' in: " << r.err;
  EXPECT_EQ(vim::test::count_files(out), 0) << "files left in --out";
}

INSTANTIATE_TEST_SUITE_P(Images, BadImages, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

// --info goes through the same reader.
TEST(BadImagesInfo, InfoReportsTheSameError) {
  vim::test::TempDir dir("bad_info");
  const auto r = vim::test::run_pipeline("--info " + vim::test::quote(dir / "absent.nrrd"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("absent.nrrd: file does not exist"), std::string::npos) << r.err;
}

// Robustness of the real CLI: a non-empty --out is refused unless --overwrite, option
// values out of range are usage errors naming the option, hand-written broken MetaImage files fail
// with one line naming the file, and SIGKILL during a run never leaves an incomplete file under a
// final name (every file is written to a hidden temporary name and renamed, atomic_file.hpp).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vtkNew.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>

#include "cli_in_process.hpp"
#include "process_output.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::test;
namespace fs = std::filesystem;

namespace {

// Hand-written MetaImage: `header` lines (without ElementDataFile) then raw float data.
void write_mha(const fs::path& path, const std::string& header, const std::vector<float>& data) {
  std::ofstream out(path, std::ios::binary);
  out << header << "ElementDataFile = LOCAL\n";
  out.write(reinterpret_cast<const char*>(data.data()),
            static_cast<std::streamsize>(data.size() * sizeof(float)));
}

std::string mha_header(const std::string& dims, const std::string& spacing = "1 1 1",
                       const std::string& extra = "") {
  const int n = static_cast<int>(std::count(dims.begin(), dims.end(), ' ')) + 1;
  std::string origin = "0";
  for (int a = 1; a < n; ++a) origin += " 0";
  return "ObjectType = Image\nNDims = " + std::to_string(n) +
         "\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
         "DimSize = " +
         dims + "\nElementSpacing = " + spacing + "\nOffset = " + origin + "\n" + extra +
         "ElementType = MET_FLOAT\n";
}

// A 3D block with a stiff sphere so VIM has work to do: n×n×n voxels of 1 mm centred at 0.
void write_sphere_block(const fs::path& path, int n) {
  OrientedImage<3> img;
  const double o = -0.5 * (n - 1);
  img.image = Image<3>({{n, n, n}}, {{1, 1, 1}}, {{o, o, o}}, 10.0f);
  for (long k = 0; k < n; ++k)
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) {
        const double x = o + i, y = o + j, z = o + k, r = 0.3 * n;
        if (x * x + y * y + z * z < r * r) img.image.data[i + n * (j + n * k)] = 40.0f;
      }
  write_image<3>(img, path.string());
}

class Robustness : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vim_robust_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    out_ = dir_ / "out";
  }
  void TearDown() override { fs::remove_all(dir_); }

  ProcessResult run(std::vector<std::string> args) {
    const fs::path err = dir_ / "stderr.txt";
    return wait_cli(spawn_cli(args, err), err);
  }

  // The same command line through the CLI's main in this process (for usage errors: a process start
  // costs more than a second under the sanitizers; the other tests here start the executable).
  static ProcessResult run_in_process(std::vector<std::string> args) {
    const CliResult r = run_pipeline_in_process(std::move(args));
    ProcessResult p;
    p.code = r.code;
    p.err = r.err;
    return p;
  }

  // A small image that meshes in well under a second.
  std::string small_image() {
    const fs::path p = dir_ / "small.mha";
    if (!fs::exists(p)) write_sphere_block(p, 10);
    return p.string();
  }

  // The one-line error contract: `code`, one "vim-pipeline: error:" line containing every part.
  static void expect_one_line_error(const ProcessResult& r, int code, const std::vector<std::string>& parts) {
    EXPECT_EQ(r.signal, 0) << "killed by signal " << r.signal << ": " << r.err;
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line only: " << r.err;
    for (const auto& p : parts)
      EXPECT_NE(r.err.find(p), std::string::npos) << "message lacks '" << p << "': " << r.err;
  }

  bool out_is_empty() const { return !fs::exists(out_) || fs::is_empty(out_); }

  // A bad image: exit 1, one line naming the file and `problem`, nothing in --out.
  void expect_bad_image(const fs::path& image, const std::vector<std::string>& problem) {
    std::vector<std::string> parts{image.filename().string()};
    parts.insert(parts.end(), problem.begin(), problem.end());
    const ProcessResult r = run({image.string(), "--nodes", "64", "--out", out_.string(), "-q"});
    expect_one_line_error(r, 1, parts);
    EXPECT_TRUE(out_is_empty()) << "files left in --out";
  }

  fs::path dir_, out_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// --out DIR and --overwrite

TEST_F(Robustness, RerunIntoNonEmptyOutRefusesUnlessOverwrite) {
  const std::string img = small_image();
  const std::vector<std::string> args{img,        "--nodes", "64",    "--max-iterations", "2",
                                      "--export", "none",    "--out", out_.string()};
  ProcessResult r = run(args);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out_ / "report.json"));
  const auto before = fs::last_write_time(out_ / "report.json");

  r = run(args);
  expect_one_line_error(r, 1, {out_.string(), "not empty", "--overwrite"});
  EXPECT_EQ(fs::last_write_time(out_ / "report.json"), before) << "a refused run touched the old outputs";

  auto with_overwrite = args;
  with_overwrite.push_back("--overwrite");
  r = run(with_overwrite);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(incomplete_reason(out_ / "report.json"), "");
}

TEST_F(Robustness, StrayFileInOutIsRefusedAndKept) {
  fs::create_directories(out_);
  std::ofstream(out_ / "notes.txt") << "mine\n";
  const ProcessResult r = run({small_image(), "--nodes", "64", "--out", out_.string()});
  expect_one_line_error(r, 1, {out_.string(), "--overwrite"});
  EXPECT_EQ(slurp(out_ / "notes.txt"), "mine\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(out_), fs::directory_iterator{}), 1);
}

TEST_F(Robustness, OutIsARegularFile) {
  std::ofstream(out_) << "x";
  const ProcessResult r = run({small_image(), "--nodes", "64", "--out", out_.string()});
  expect_one_line_error(r, 1, {out_.string(), "not a directory"});
  EXPECT_EQ(slurp(out_), "x");
}

TEST_F(Robustness, FailedRunLeavesNewOutAbsent) {
  // Fails after the output directory is validated (a 3D mesh needs 8 nodes).
  const ProcessResult r = run({small_image(), "--nodes", "5", "--out", out_.string()});
  expect_one_line_error(r, 1, {"--nodes", "5"});
  EXPECT_FALSE(fs::exists(out_));
}

// An --out that cannot be created (below a regular file) is refused at once, not after the meshing.
TEST_F(Robustness, OutBelowARegularFileIsRefusedUpFront) {
  std::ofstream(dir_ / "afile") << "x";
  const fs::path out = dir_ / "afile" / "sub";
  const ProcessResult r = run({small_image(), "--nodes", "64", "--out", out.string()});
  expect_one_line_error(r, 1, {"--out", "cannot be created", "is not a directory"});
  EXPECT_EQ(slurp(dir_ / "afile"), "x");
}

// A failed --overwrite run removes what it wrote; if that replaced files of the earlier run, the earlier
// report.json goes too (it would list files that are gone), so nothing left looks like a valid result.
TEST_F(Robustness, FailedOverwriteRunLeavesNoStaleReport) {
  const std::string img = small_image();
  ASSERT_EQ(run({img, "--nodes", "64", "--export", "none", "--out", out_.string(), "-q"}).code, 0);
  ASSERT_TRUE(fs::exists(out_ / "report.json"));
  ASSERT_TRUE(fs::exists(out_ / "figures" / "energy.png"));
  fs::remove(out_ / "figures" / "energy.png");
  fs::create_directories(out_ / "figures" / "energy.png" / "blocker");  // the rename onto it must fail
  const ProcessResult r =
      run({img, "--nodes", "64", "--export", "none", "--overwrite", "--out", out_.string(), "-q"});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_FALSE(fs::exists(out_ / "report.json")) << "a stale report.json survived";
  EXPECT_FALSE(fs::exists(out_ / "mesh.vtu"));
  // Without an earlier run's files being replaced, a failure keeps the earlier result whole.
  fs::remove_all(out_);
  ASSERT_EQ(run({img, "--nodes", "64", "--export", "none", "--out", out_.string(), "-q"}).code, 0);
  const std::string before = slurp(out_ / "report.json");
  const ProcessResult early = run({img, "--nodes", "5", "--overwrite", "--out", out_.string(), "-q"});
  EXPECT_EQ(early.code, 1);
  EXPECT_EQ(slurp(out_ / "report.json"), before);
}

// ---------------------------------------------------------------------------------------------
// Option values out of range: usage error (exit 2) naming the option, nothing created.

struct BadOption {
  std::vector<std::string> args;
  std::string option;
};

TEST_F(Robustness, OptionValuesOutOfRange) {
  const std::vector<BadOption> cases = {
      {{"--lambda", "1.5"}, "--lambda"},
      {{"--lambda", "-0.1"}, "--lambda"},
      {{"--lambda", "nan"}, "--lambda"},
      {{"--lambda", "0.5x"}, "--lambda"},
      {{"--max-dihedral", "80"}, "--max-dihedral"},
      {{"--max-dihedral", "180"}, "--max-dihedral"},
      {{"--nodes", "3"}, "--nodes"},
      {{"--nodes", "1000000000"}, "--nodes"},
      {{"--nodes", "many"}, "--nodes"},
      {{"--threads", "-1"}, "--threads"},
      {{"--threads", "5000"}, "--threads"},
      {{"--degree", "3"}, "--degree"},
      {{"--degree", "0"}, "--degree"},
      {{"--max-iterations", "-1"}, "--max-iterations"},
      {{"--spacing", "0"}, "--spacing"},
      {{"--spacing", "-2"}, "--spacing"},
      {{"--mesher", "delaunay"}, "--mesher"},
      {{"--export", "stl"}, "--export"},
      {{"--nodes", "100", "--spacing", "1"}, "--spacing"},
  };
  const std::string img = small_image();
  for (const auto& c : cases) {
    std::vector<std::string> args{img, "--out", out_.string()};
    args.insert(args.end(), c.args.begin(), c.args.end());
    std::string shown;
    for (const auto& a : c.args) shown += a + " ";
    SCOPED_TRACE(shown);
    const ProcessResult r = run_in_process(args);
    expect_one_line_error(r, 2, {c.option});
    EXPECT_FALSE(fs::exists(out_)) << "a usage error created --out";
  }
}

TEST_F(Robustness, MissingOutIsAUsageError) {
  const ProcessResult r = run({small_image(), "--nodes", "64"});
  expect_one_line_error(r, 2, {"--out"});
}

// ---------------------------------------------------------------------------------------------
// Hand-written MetaImage files that ITK's own writer would never produce.

TEST_F(Robustness, MhaTruncatedVoxelData) {
  const fs::path p = dir_ / "truncated.mha";
  write_mha(p, mha_header("8 8 8"), std::vector<float>(100, 1.0f));  // 512 declared
  expect_bad_image(p, {"voxel data"});
}

// ASCII and compressed voxel data cannot be sized exactly from the file, but they have a lower
// bound (one character per ASCII voxel; deflate compresses at most 1032:1): a file below it is
// refused before ITK allocates the declared 4 GB (fuzz_image_header: regress_mha_ascii_huge_oom).
TEST_F(Robustness, MhaAsciiDataFarShorterThanDeclared) {
  const fs::path p = dir_ / "ascii_huge.mha";
  std::ofstream(p, std::ios::binary)
      << "ObjectType = Image\nNDims = 3\nBinaryData = False\nDimSize = 1000 1000 1000\n"
         "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n1 2 3 4 5 6 7 8\n";
  const auto t0 = std::chrono::steady_clock::now();
  expect_bad_image(p, {"truncated", "ASCII", "1000000000 voxels"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
}

TEST_F(Robustness, MhaCompressedDataShorterThanDeflateAllows) {
  const fs::path p = dir_ / "zip_huge.mha";
  std::ofstream out(p, std::ios::binary);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nCompressedData = True\nCompressedDataSize = 64\n"
         "DimSize = 1000 1000 1000\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n"
      << std::string(64, 'x');
  out.close();
  expect_bad_image(p, {"truncated", "compressed"});
}

TEST_F(Robustness, NrrdGzipDataShorterThanDeflateAllows) {
  const fs::path p = dir_ / "gz_huge.nrrd";
  std::ofstream out(p, std::ios::binary);
  out << "NRRD0004\ntype: float\ndimension: 3\nsizes: 1000 1000 1000\nspacings: 1 1 1\nendian: "
         "little\nencoding: gzip\n\n"
      << std::string(64, 'x');
  out.close();
  expect_bad_image(p, {"truncated", "gzip"});
}

// Voxel data that ITK 5.2 reads without complaint although it is short or corrupt (it zero-fills or
// repeats values): checked independently of ITK (itk_image_io.cpp, DataCheck). Each bad file has a
// good twin, read back exactly, so the check cannot pass by refusing everything.
namespace {

std::vector<unsigned char> zlib_compress(const std::vector<float>& v) {
  uLongf n = compressBound(static_cast<uLong>(v.size() * sizeof(float)));
  std::vector<unsigned char> out(n);
  EXPECT_EQ(compress2(out.data(), &n, reinterpret_cast<const Bytef*>(v.data()),
                      static_cast<uLong>(v.size() * sizeof(float)), 6),
            Z_OK);
  out.resize(n);
  return out;
}

void write_compressed_mha(const fs::path& p, const std::string& dims, const std::vector<unsigned char>& z) {
  std::ofstream out(p, std::ios::binary);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nCompressedData = True\nCompressedDataSize = "
      << z.size() << "\nDimSize = " << dims
      << "\nElementSpacing = 1 1 1\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  out.write(reinterpret_cast<const char*>(z.data()), static_cast<std::streamsize>(z.size()));
}

void write_ascii_mha(const fs::path& p, const std::string& dims, const std::string& values) {
  std::ofstream(p, std::ios::binary)
      << "ObjectType = Image\nNDims = 3\nBinaryData = False\nDimSize = " << dims
      << "\nElementSpacing = 1 1 1\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n"
      << values;
}

std::vector<float> ramp(int n) {
  std::vector<float> v(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) v[static_cast<std::size_t>(k)] = 1.0f + 0.25f * static_cast<float>(k % 37);
  return v;
}

}  // namespace

TEST_F(Robustness, MhaCompressedDataMustInflateToTheDeclaredSize) {
  const std::vector<float> v = ramp(512);
  const fs::path good = dir_ / "zgood.mha";
  write_compressed_mha(good, "8 8 8", zlib_compress(v));
  const auto img = read_image<3>(good.string());
  ASSERT_EQ(img.image.data.size(), v.size());
  EXPECT_TRUE(std::equal(v.begin(), v.end(), img.image.data.begin()));

  const fs::path half = dir_ / "zhalf.mha";  // a complete stream of half the voxels
  write_compressed_mha(half, "8 8 8", zlib_compress(std::vector<float>(v.begin(), v.begin() + 256)));
  expect_bad_image(half, {"compressed data hold 1024 bytes", "512 voxels, 2048 bytes"});

  const fs::path sum = dir_ / "zchecksum.mha";  // every byte but the Adler-32 trailer intact
  auto z = zlib_compress(v);
  z[z.size() - 1] ^= 0x5a;
  write_compressed_mha(sum, "8 8 8", z);
  expect_bad_image(sum, {"corrupt compressed data", "incorrect data check"});

  const fs::path cut = dir_ / "zcut.mha";  // the stream stops half-way
  z = zlib_compress(v);
  z.resize(z.size() / 2);
  write_compressed_mha(cut, "8 8 8", z);
  expect_bad_image(cut, {"compressed"});
}

TEST_F(Robustness, MhaAsciiDataMustHoldTheDeclaredNumbers) {
  std::ostringstream all, shorter, word, nan;
  for (int k = 0; k < 216; ++k) all << 0.5 * k << (k % 12 == 11 ? "\n" : " ");
  for (int k = 0; k < 150; ++k) shorter << 5 << " ";
  shorter << std::string(200, ' ');
  for (int k = 0; k < 216; ++k) word << (k == 100 ? "x" : "3") << " ";
  for (int k = 0; k < 216; ++k) nan << (k == 100 ? "nan" : "3") << " ";
  const fs::path good = dir_ / "agood.mha";
  write_ascii_mha(good, "6 6 6", all.str());
  const auto img = read_image<3>(good.string());
  ASSERT_EQ(img.image.data.size(), 216u);
  for (int k = 0; k < 216; ++k)
    EXPECT_EQ(img.image.data[static_cast<std::size_t>(k)], 0.5f * static_cast<float>(k));

  write_ascii_mha(dir_ / "ashort.mha", "6 6 6", shorter.str());
  expect_bad_image(dir_ / "ashort.mha", {"truncated", "216 ASCII values; the file holds 150"});
  write_ascii_mha(dir_ / "aword.mha", "6 6 6", word.str());
  expect_bad_image(dir_ / "aword.mha", {"ASCII voxel 100 is 'x', not a number"});
  write_ascii_mha(dir_ / "anan.mha", "6 6 6", nan.str());
  expect_bad_image(dir_ / "anan.mha", {"ASCII voxel 100 is 'nan'", "finite"});
}

TEST_F(Robustness, NiftiShorterThanItsHeaderDeclaresIsTruncated) {
  OrientedImage<3> im;
  im.image = Image<3>({{10, 10, 10}}, {{1, 1, 1}}, {{0, 0, 0}}, 2.0f);
  im.image.data[999] = 7.0f;
  const fs::path good = dir_ / "good.nii";
  write_image<3>(im, good.string());
  EXPECT_EQ(read_image<3>(good.string()).image.data[999], 7.0f);
  const std::string bytes = slurp(good);
  ASSERT_GE(bytes.size(), 352u + 4000u);

  const fs::path cut = dir_ / "cut.nii";  // the last 100 bytes (25 voxels) missing
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 100);
  expect_bad_image(
      cut, {"truncated", "1000 voxels, 4000 bytes", "holds only " + std::to_string(bytes.size() - 100)});

  // Cut inside the 348-byte header itself (ITK would read the missing bytes as geometry).
  const fs::path header_cut = dir_ / "header_cut.nii";
  std::ofstream(header_cut, std::ios::binary) << bytes.substr(0, 300);
  expect_bad_image(header_cut, {"header is truncated", "holds 300 bytes", "348-byte NIfTI-1"});

  const fs::path gz = dir_ / "cut.nii.gz";  // a valid gzip stream of the cut file
  gzFile f = gzopen(gz.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  const std::string part = bytes.substr(0, bytes.size() - 100);
  ASSERT_EQ(gzwrite(f, part.data(), static_cast<unsigned>(part.size())), static_cast<int>(part.size()));
  gzclose(f);
  expect_bad_image(gz, {"truncated", "inflated file holds only"});

  const fs::path gz_good = dir_ / "good.nii.gz";
  f = gzopen(gz_good.c_str(), "wb");
  ASSERT_EQ(gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size())), static_cast<int>(bytes.size()));
  gzclose(f);
  EXPECT_EQ(read_image<3>(gz_good.string()).image.data[999], 7.0f);
}

TEST_F(Robustness, DoubleVoxelsBeyondFloatRangeAreNamedAsSuch) {
  const fs::path p = dir_ / "huge_double.mha";
  std::ofstream out(p, std::ios::binary);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nDimSize = 4 4 4\nElementSpacing = 1 1 1\n"
         "ElementType = MET_DOUBLE\nElementDataFile = LOCAL\n";
  std::vector<double> v(64, 1.0);
  v[5] = 1e300;
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(double)));
  out.close();
  expect_bad_image(p, {"1 voxel is NaN or Inf", "stores doubles", "beyond ±3.4e38"});
}

// MetaIO reads malformed header lines differently on each of ITK's passes (fuzz finding: a
// heap-buffer-overflow in MetaImage::M_ReadElementData); such lines are refused first.
TEST_F(Robustness, MhaMalformedHeaderLinesAreRefusedByLine) {
  const fs::path p = dir_ / "malformed.mha";
  write_mha(p, "ObjectType = Image\nNDims = 3\nDimSize 4 4 4\nElementType = MET_FLOAT\n",
            std::vector<float>(64, 1.0f));
  expect_bad_image(p, {"corrupt MetaImage header", "line 3", "Key = value"});
  const fs::path q = dir_ / "badkey.mha";
  write_mha(q, "ObjectType = Image\nND\xaeims = 3\nDimSize = 4 4 4\nElementType = MET_FLOAT\n",
            std::vector<float>(64, 1.0f));
  expect_bad_image(q, {"corrupt MetaImage header", "line 2", "key"});
  const fs::path r = dir_ / "ctrl.mha";
  write_mha(r, mha_header("4 4 4", "1 1\x01 1"), std::vector<float>(64, 1.0f));
  expect_bad_image(r, {"corrupt MetaImage header", "ElementSpacing", "control character"});
  const fs::path v = dir_ / "longvalue.mha";
  write_mha(v,
            "ObjectType = Image" + std::string(300, '6') +
                "\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_FLOAT\n",
            std::vector<float>(64, 1.0f));
  expect_bad_image(v, {"corrupt MetaImage header", "ObjectType", "longer than 250"});
}

// teem smashed its stack on a long NRRD header line without ':' (fuzz finding): such lines are
// refused first, naming the line.
TEST_F(Robustness, NrrdMalformedHeaderLineIsRefusedByLine) {
  const fs::path p = dir_ / "garbage_line.nrrd";
  std::ofstream out(p, std::ios::binary);
  out << "NRRD0004\ntype: short\n"
      << std::string(400, '6') << "\nsizes: 4 3 4\nencoding: raw\nendian: little\n\n"
      << std::string(96, '\0');
  out.close();
  expect_bad_image(p, {"corrupt NRRD header", "line 3"});
  // A long line with a ':' (teem's error message about it overflowed a stack buffer).
  const fs::path q = dir_ / "long_line.nrrd";
  std::ofstream o(q, std::ios::binary);
  o << "NRRD0004\ntype: short\ndimension: 3\n"
    << std::string(14, '6') << ":" << std::string(600, '6')
    << "\nsizes: 4 3 4\nencoding: raw\nendian: little\n\n"
    << std::string(96, '\0');
  o.close();
  expect_bad_image(q, {"corrupt NRRD header", "line 4", "longer than 500"});
}

TEST_F(Robustness, MhaGarbageHeader) {
  const fs::path p = dir_ / "garbage.mha";
  std::ofstream(p, std::ios::binary) << "this is not a MetaImage header\n\x01\x02\x03 rubbish\n";
  expect_bad_image(p, {});
}

TEST_F(Robustness, MhaHeaderWithoutDimSize) {
  const fs::path p = dir_ / "nodims.mha";
  write_mha(p, "ObjectType = Image\nNDims = 3\nElementType = MET_FLOAT\n", std::vector<float>(8, 1.0f));
  expect_bad_image(p, {});
}

TEST_F(Robustness, MhaHugeDimSizeIsRefusedBeforeAllocating) {
  const fs::path p = dir_ / "huge.mha";
  write_mha(p, mha_header("100000 100000 100000"), std::vector<float>(8, 1.0f));
  const auto t0 = std::chrono::steady_clock::now();
  expect_bad_image(p, {"voxels"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
}

TEST_F(Robustness, MhaZeroSpacing) {
  const fs::path p = dir_ / "zero_spacing.mha";
  write_mha(p, mha_header("4 4 4", "1 0 1"), std::vector<float>(64, 1.0f));
  expect_bad_image(p, {"spacing", "axis 1"});
}

TEST_F(Robustness, MhaNegativeSpacing) {
  const fs::path p = dir_ / "negative_spacing.mha";
  write_mha(p, mha_header("4 4 4", "1 1 -2"), std::vector<float>(64, 1.0f));
  expect_bad_image(p, {"spacing"});
}

TEST_F(Robustness, MhaVectorPixels) {
  const fs::path p = dir_ / "rgb.mha";
  write_mha(p, mha_header("4 4 4", "1 1 1", "ElementNumberOfChannels = 3\n"),
            std::vector<float>(3 * 64, 1.0f));
  expect_bad_image(p, {"3 components"});
}

TEST_F(Robustness, MhaNaNPatch) {
  const fs::path p = dir_ / "nan_patch.mha";
  std::vector<float> v(6 * 6 * 6, 5.0f);
  for (int k = 2; k < 4; ++k)
    for (int j = 2; j < 4; ++j)
      for (int i = 2; i < 4; ++i) v[i + 6 * (j + 6 * k)] = std::numeric_limits<float>::quiet_NaN();
  write_mha(p, mha_header("6 6 6"), v);
  expect_bad_image(p, {"8 voxels are NaN or Inf", "(2,2,2)"});
}

TEST_F(Robustness, MhaOneVoxelThick) {
  const fs::path p = dir_ / "slab.mha";
  write_mha(p, mha_header("6 6 1"), std::vector<float>(36, 1.0f));
  expect_bad_image(p, {"1 voxel thick", "axis 2"});
}

TEST_F(Robustness, MhaFourDimensions) {
  const fs::path p = dir_ / "four_d.mha";
  write_mha(p, mha_header("2 2 2 2", "1 1 1 1"), std::vector<float>(16, 1.0f));
  expect_bad_image(p, {"4 dimensions"});
}

TEST_F(Robustness, MhaTwoByTwoByTwoMeshesOrFailsCleanly) {
  // The smallest meshable image: must either mesh (every output complete) or fail on one line.
  const fs::path p = dir_ / "tiny.mha";
  write_mha(p, mha_header("2 2 2"), {1, 2, 3, 4, 5, 6, 7, 8});
  const ProcessResult r = run({p.string(), "--nodes", "8", "--out", out_.string(), "-q"});
  ASSERT_EQ(r.signal, 0) << r.err;
  if (r.code == 0) {
    EXPECT_EQ(r.err, "");
    for (const auto& f : final_files(out_)) EXPECT_EQ(incomplete_reason(f), "") << f;
    EXPECT_TRUE(fs::exists(out_ / "mesh.vtu"));
  } else {
    expect_one_line_error(r, 1, {"tiny.mha"});
    EXPECT_TRUE(out_is_empty());
  }
}

// ---------------------------------------------------------------------------------------------
// SIGKILL during a run: whatever is left under a final name is complete. The kills are placed at
// fractions of the measured uninterrupted run, the last ones near its end (the writes), whatever its
// length: a small mesh (400 nodes) serves, and the test runs the CLI seven times (also sanitized).

TEST_F(Robustness, SigkillNeverLeavesAnIncompleteFinalFile) {
  const fs::path img = dir_ / "sphere.mha";
  write_sphere_block(img, 24);
  const std::vector<std::string> base{
      img.string(), "--nodes", "400", "--max-iterations", "6", "--threshold", "20", "--threads", "1"};

  // Uninterrupted run: measures the duration and checks the checker accepts a complete output.
  auto args = base;
  args.insert(args.end(), {"--out", out_.string(), "-q"});
  const auto t0 = std::chrono::steady_clock::now();
  const ProcessResult full = run(args);
  const double duration = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(full.code, 0) << full.err;
  const auto complete = final_files(out_);
  ASSERT_FALSE(complete.empty());
  for (const auto& f : complete) EXPECT_EQ(incomplete_reason(f), "") << f;

  // Kills spread over the run, the last ones close to its end (the write phase).
  const std::vector<double> fractions{0.15, 0.5, 0.8, 0.9, 0.95, 0.98};
  int left_files = 0;
  for (std::size_t k = 0; k < fractions.size(); ++k) {
    const fs::path out = dir_ / ("killed" + std::to_string(k));
    auto a = base;
    a.insert(a.end(), {"--out", out.string(), "-q"});
    const fs::path err = dir_ / "stderr_killed.txt";
    const pid_t pid = spawn_cli(a, err);
    const auto delay = std::chrono::duration<double>(std::max(0.05, fractions[k] * duration));
    std::this_thread::sleep_for(delay);
    ::kill(pid, SIGKILL);
    const ProcessResult r = wait_cli(pid, err);
    SCOPED_TRACE("killed after " + std::to_string(delay.count()) + " s");
    for (const auto& f : final_files(out)) {
      ++left_files;
      EXPECT_EQ(incomplete_reason(f), "") << f;
    }
    (void)r;
  }
  std::cout << "[ info ] run " << duration << " s; " << left_files << " final-named files left by "
            << fractions.size() << " killed runs, all complete\n";
}

// Every crash reproducer the fuzzers found (fuzz/corpus/image/regress_*: the first byte picks .nrrd
// when odd, .mha when even, the rest is the file; fuzz/corpus/nifti/regress_*: a .nii file) run
// through the CLI's main in the test's own process (a crash ends the test; a process start costs more
// than a second under the sanitizers). Truth: the bad-input contract (README): the run ends normally
// with status 0 or 1, and a failure is one "vim-pipeline: error:" line naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_in_process.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim::test;

namespace {

void check_reproducers(const std::string& corpus, bool ext_from_first_byte) {
  const auto dir = scratch_dir("fuzz_regressions", corpus);
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(VIM_SOURCE_DIR) / "fuzz" / "corpus" / corpus)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("regress_", 0) != 0) continue;
    ++n;
    std::string bytes = slurp(e.path());
    std::string ext = ".nii";
    if (ext_from_first_byte) {
      if (bytes.empty()) continue;
      ext = (static_cast<unsigned char>(bytes[0]) & 1) ? ".nrrd" : ".mha";
      bytes.erase(0, 1);
    }
    const fs::path image = dir / (name + ext);
    std::ofstream(image, std::ios::binary) << bytes;
    const CliResult r = run_pipeline_in_process({image.string(), "--nodes", "64", "--max-iterations", "1",
                                                 "--out", (dir / ("out_" + name)).string(), "-q"});
    SCOPED_TRACE(name);
    EXPECT_TRUE(r.code == 0 || r.code == 1) << "exit " << r.code << ": " << r.err;
    if (r.code == 1) {
      EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_NE(r.err.find(image.filename().string()), std::string::npos) << r.err;
    }
  }
  EXPECT_GT(n, 0) << "no reproducer in fuzz/corpus/" << corpus;
}

}  // namespace

TEST(FuzzRegressions, ImageHeaderReproducersFailCleanly) { check_reproducers("image", true); }

TEST(FuzzRegressions, NiftiReproducersFailCleanly) { check_reproducers("nifti", false); }

// Faults of the real CLI. Truth: the format of each file left under a final name (a VTU that
// vtkXMLUnstructuredGridReader reads and that ends with </VTKFile>, JSON that parses, a CSV with
// whole lines, a PNG ending in its IEND chunk; process_output.hpp), checked after SIGKILL at 20
// random moments of a multi-needle run, and after a full disk (RLIMIT_FSIZE in the child: write()
// fails with EFBIG, as on a full file system) at several sizes: one error line, exit status 1, and
// nothing incomplete under a final name.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "process_output.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim::test;

namespace {

// A 2D elastogram (two inclusions, 60 x 60 mm centred at 0) and a scenario with two needles.
struct MultiNeedleCase {
  fs::path image, scenario;
  std::vector<std::string> args(const fs::path& out) const {
    return {image.string(), "--nodes",         "300",   "--max-iterations", "3", "--threads", "1",
            "--simulate",   scenario.string(), "--out", out.string(),       "-q"};
  }
};

MultiNeedleCase make_case(const fs::path& dir) {
  MultiNeedleCase c{dir / "inclusions.mha", dir / "two_needles.yaml"};
  const std::string cmd =
      std::string(VIM_PHANTOM_EXE) + " two-inclusions " + c.image.string() + " --size 40 >/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  std::ofstream(c.scenario) << R"(material: {youngs_modulus: image, poisson_ratio: 0.3, clamp: [1, 1000]}
boundary_conditions:
  - {type: fixed, region: {box_face: y_max}}
needles:
  - {name: left, entry: [-10, -30], direction: [0, 1], depth: 25, steps: 6, diameter: 1, friction: {model: stick}}
  - {name: right, entry: [10, -30], direction: [0, 1], depth: 20, steps: 5, diameter: 1, friction: {model: stick}}
output: {every: 1}
)";
  return c;
}

}  // namespace

TEST(Faults, SigkillAtRandomMomentsOfAMultiNeedleRunLeavesOnlyCompleteFiles) {
  const auto dir = scratch_dir("faults", "sigkill");
  const MultiNeedleCase c = make_case(dir);
  const auto t0 = std::chrono::steady_clock::now();
  const ProcessResult full = run_to_end(c.args(dir / "full"), dir / "err.txt");
  const double duration = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(full.code, 0) << full.err;
  const auto complete = final_files(dir / "full");
  ASSERT_TRUE(fs::exists(dir / "full" / "left" / "needle.csv") &&
              fs::exists(dir / "full" / "right" / "needle.csv"));
  for (const auto& f : complete) ASSERT_EQ(incomplete_reason(f), "") << f;  // the checker accepts a whole run

  std::mt19937 rng(34);  // fixed seed: the same 20 kill times at every run of the test
  std::uniform_real_distribution<double> moment(0.0, 1.1);
  long left = 0;
  for (int k = 0; k < 20; ++k) {
    const fs::path out = dir / ("killed" + std::to_string(k));
    const pid_t pid = spawn_cli(c.args(out), dir / "err.txt");
    left += kill_and_count_complete_files(pid, moment(rng) * duration, duration, dir / "err.txt", out);
  }
  std::cout << "[ info ] run " << duration << " s; " << left << " final-named files left by 20 killed runs\n";
}

TEST(Faults, FullDiskGivesOneErrorAndNoFinalNamedPartialFile) {
  const auto dir = scratch_dir("faults", "full_disk");
  const MultiNeedleCase c = make_case(dir);
  // Limits below the smallest output, inside mesh.vtu, and among the step files of the needles (the
  // largest output, a step file, is about 65 KB).
  for (long limit : {2048L, 20000L, 62000L}) {
    SCOPED_TRACE("RLIMIT_FSIZE " + std::to_string(limit) + " bytes");
    const fs::path out = dir / ("out" + std::to_string(limit));
    const ProcessResult r = run_to_end(c.args(out), dir / "err.txt", limit);
    EXPECT_EQ(r.signal, 0) << "killed by signal " << r.signal;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line only: " << r.err;
    EXPECT_NE(r.err.find("cannot write " + out.string()), std::string::npos) << "names the file: " << r.err;
    for (const auto& f : final_files(out)) EXPECT_EQ(incomplete_reason(f), "") << f;
  }
}

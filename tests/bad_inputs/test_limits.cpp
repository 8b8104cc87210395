// Limits of the CLI, each a clear one-line error before any meshing and nothing in --out. Truth:
// arithmetic on the initial grid (cube [0, 3]^3 of the table1 phantom: spacing h gives (3/h + 1)^3
// nodes; 3D VIM keys hold 2^21 = 2097152 nodes, node ids 2^31 - 1) and the documented memory model
// (200 MB + 27 B per voxel + 1600 B per node: 751^3 nodes need about 677 GB, more than any test
// machine has; 1M is far below the libraries alone).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>
#include <vim/pipeline/common/memory_limit.hpp>

#include "cli_in_process.hpp"

using namespace vim::pipeline;
using namespace vim::test;

namespace {

class Limits : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(run_command(VIM_PHANTOM_EXE, "table1 " + quote(dir_ / "cube.mha") + " --size 12").code, 0);
  }
  // Runs the CLI on the cube with `args`; expects exit 1, one error line holding every part, no output.
  void expect_refused(const std::string& args, const std::vector<std::string>& parts) {
    const std::string out = dir_ / "out";
    const CliResult r = run_pipeline(quote(dir_ / "cube.mha") + " " + args + " -q --out " + quote(out));
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    for (const auto& p : parts)
      EXPECT_NE(r.err.find(p), std::string::npos) << "lacks '" << p << "': " << r.err;
    EXPECT_EQ(count_files(out), 0) << "files left in --out";
  }
  TempDir dir_{"limits"};
};

}  // namespace

TEST_F(Limits, TinySpacingIsAClearErrorNotAnOverflow) {
  expect_refused("--spacing 1e-300", {"spacing", "2147483647"});    // 1e9 + 1 nodes per axis: 1e27
  expect_refused("--spacing 1e-3", {"spacing", "2147483647"});      // 3001^3 = 2.7e10
  expect_refused("--spacing 0.01", {"--spacing 0.01", "2097152"});  // 301^3 = 2.7e7 > 2^21
}

TEST_F(Limits, NodeBudgetBeyondTheKeyRangeIsRefusedBeforeMeshing) {
  expect_refused("--nodes 100000000", {"--nodes 100000000", "2097152", "21 bits"});
}

TEST_F(Limits, MemoryEstimateAboveMaxMemoryIsRefused) {
  expect_refused("--nodes 1000 --max-memory 1M", {"estimated peak memory", "--max-memory"});
  // The default limit is the memory available to the process: 751^3 grid nodes cannot fit.
  expect_refused("--mesher grid --spacing 0.004", {"estimated peak memory", "available"});
  const std::string out = dir_ / "ok";
  const CliResult ok =
      run_pipeline(quote(dir_ / "cube.mha") + " --nodes 125 --max-iterations 1 --export none " +
                   "--max-memory 64G -q --out " + quote(out));
  EXPECT_EQ(ok.code, 0) << ok.err;
}

TEST_F(Limits, MaxMemoryValuesOutsideTheGrammarAreUsageErrors) {
  for (const char* bad : {"abc", "0", "-5G", "8X", "nan"}) {
    const CliResult r = run_pipeline_in_process(quote(dir_ / "cube.mha") + " --max-memory " + bad +
                                                " --out " + quote(dir_ / "o"));
    EXPECT_EQ(r.code, 2) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("--max-memory"), std::string::npos) << r.err;
  }
  EXPECT_EQ(parse_memory_size("8G").value(), 8.0 * 1024 * 1024 * 1024);
  EXPECT_EQ(parse_memory_size("512M").value(), 512.0 * 1024 * 1024);
  EXPECT_EQ(parse_memory_size("1000").value(), 1000.0);
  EXPECT_EQ(parse_memory_size("2kB").value(), 2048.0);
}

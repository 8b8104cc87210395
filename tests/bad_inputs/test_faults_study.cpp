// Faults of a study run through the real CLI (vim-pipeline IMAGE --study FILE). Truths: the format of
// each file left under a final name (process_output.hpp) after SIGKILL at random moments; the study.csv
// of an uninterrupted run, which the same command run again after each kill must reproduce byte for
// byte (a study resumes its incomplete cases); and a full disk (RLIMIT_FSIZE in the child, write()
// fails with EFBIG): exit status 1, one error line, the system's reason for every file that could not
// be written, nothing incomplete under a final name.
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
#include "study_inputs.hpp"

namespace fs = std::filesystem;
using namespace vim::test;

namespace {

// study_inputs.hpp's phantom and needle scenario, three depths (three cases, about 2 s in all).
void write_study(const fs::path& dir) {
  write_study_inputs(dir);
  std::ofstream(dir / "study.yaml") << "scenario: base.yaml\ngrid:\n  depth: [1.0, 1.25, 1.5]\n";
}

std::vector<std::string> study_args(const fs::path& dir, const fs::path& out) {
  return {(dir / "in.mha").string(),
          "--nodes",
          "100",
          "--max-iterations",
          "3",
          "--export",
          "none",
          "-q",
          "--study",
          (dir / "study.yaml").string(),
          "--out",
          out.string()};
}

}  // namespace

TEST(StudyFaults, SigkillAtRandomMomentsThenTheSameCommandGivesTheUninterruptedTable) {
  const auto dir = scratch_dir("faults", "study_sigkill");
  write_study(dir);
  const auto t0 = std::chrono::steady_clock::now();
  const ProcessResult full = run_to_end(study_args(dir, dir / "full"), dir / "err.txt");
  const double duration = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(full.code, 0) << full.err;
  const std::string table = slurp(dir / "full" / "study.csv");
  ASSERT_EQ(read_study_csv(dir / "full" / "study.csv").size(), 3u);
  for (const auto& f : final_files(dir / "full")) ASSERT_EQ(incomplete_reason(f), "") << f;

  std::mt19937 rng(341);  // fixed seed: the same kill times at every run of the test
  std::uniform_real_distribution<double> moment(0.0, 1.1);
  for (int k = 0; k < 4; ++k) {
    const fs::path out = dir / ("killed" + std::to_string(k));
    const pid_t pid = spawn_cli(study_args(dir, out), dir / "err.txt");
    kill_and_count_complete_files(pid, moment(rng) * duration, duration, dir / "err.txt", out);
    const ProcessResult resumed = run_to_end(study_args(dir, out), dir / "err.txt");
    EXPECT_EQ(resumed.code, 0) << resumed.err;
    EXPECT_EQ(slurp(out / "study.csv"), table);
  }
}

TEST(StudyFaults, FullDiskGivesOneErrorWithTheReasonAndNoFinalNamedPartialFile) {
  const auto dir = scratch_dir("faults", "study_full_disk");
  write_study(dir);
  // Below study.csv (about 450 bytes when every case failed; stderr, also a file, holds the one
  // line), below case.yaml (about 860), and among a case's step files (5 KB and 28 KB).
  for (long limit : {300L, 800L, 8000L}) {
    SCOPED_TRACE("RLIMIT_FSIZE " + std::to_string(limit) + " bytes");
    const fs::path out = dir / ("out" + std::to_string(limit));
    const ProcessResult r = run_to_end(study_args(dir, out), dir / "err.txt", limit);
    EXPECT_EQ(r.signal, 0) << "killed by signal " << r.signal;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << "one line only: " << r.err;
    for (const auto& f : final_files(out)) EXPECT_EQ(incomplete_reason(f), "") << f;
    if (limit == 300) {
      EXPECT_NE(
          r.err.find("cannot write " + (out / "study.csv").string() + ": File too large (is the disk full?)"),
          std::string::npos)
          << r.err;
      continue;
    }
    // Every case failed, and its row names the file and the reason.
    const auto rows = read_study_csv(out / "study.csv");
    ASSERT_EQ(rows.size(), 3u);
    for (const auto& row : rows) {
      EXPECT_EQ(row.at("status"), "failed");
      EXPECT_NE(row.at("message").find("cannot write " + (out / "cases" / row.at("case")).string()),
                std::string::npos)
          << row.at("message");
      EXPECT_NE(row.at("message").find(": File too large (is the disk full?)"), std::string::npos)
          << row.at("message");
    }
  }
}

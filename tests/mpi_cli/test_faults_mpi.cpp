// Faults of a simulation on two MPI ranks (`mpirun -np 2 vim-pipeline IMAGE --simulate ...`, rank 0
// writes the output folder). Truths: the format of every file left under a final name
// (process_output.hpp: a .pvtu is complete only when every piece it names is a complete .vtu; needle.csv
// has whole lines; report.json parses), checked after mpirun and both ranks are killed with SIGKILL at
// random moments; and a full disk (RLIMIT_FSIZE in each rank, write() fails with EFBIG as on a full
// file system): exit status 1, exactly one `vim-pipeline: error:` line naming the file and the system's
// reason, and nothing incomplete under a final name.
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

// study_inputs.hpp's phantom (12³ voxels) and a stuck needle of six steps, every step written (a .pvtu
// and one .vtu piece per rank each).
void write_inputs(const fs::path& dir) {
  write_study_inputs(dir);
  std::ofstream(dir / "six_steps.yaml")
      << "units: {length: mm, modulus: kPa}\n"
         "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
         "boundary_conditions:\n"
         "  - {type: fixed, region: {box_face: x_max}}\n"
         "needle: {entry: [0, 1.5, 1.5], direction: [1, 0, 0], depth: 1.5, "
         "steps: 6, diameter: 0.2, model: kinematic, friction: {model: stick}}\n"
         "targets: [{name: ahead, position: [2.2, 1.5, 1.5]}]\n"
         "output: {every: 1}\n";
}

// The argument vector of `mpirun -np 2 vim-pipeline ...` (through env: mpirun refuses root otherwise).
// Each rank runs under `sh -c`, which ignores SIGXFSZ and, for file_size_limit > 0, starts
// vim-pipeline through prlimit --fsize. The shared-memory transport is off (`--mca btl self,tcp`): its
// backing file in /dev/shm would hit the same limit inside MPI_Init, which a full disk does not.
std::vector<std::string> mpirun_args(const fs::path& dir, const fs::path& out, long file_size_limit = 0) {
  const std::string limit =
      file_size_limit > 0 ? "prlimit --fsize=" + std::to_string(file_size_limit) + " " : "";
  return {"/usr/bin/env",
          "OMPI_ALLOW_RUN_AS_ROOT=1",
          "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1",
          VIM_MPIEXEC,
          "-np",
          "2",
          "--oversubscribe",
          "--mca",
          "btl",
          "self,tcp",
          "/bin/sh",
          "-c",
          "trap '' XFSZ; exec " + limit + "\"$0\" \"$@\"",
          VIM_PIPELINE_EXE,
          (dir / "in.mha").string(),
          "--nodes",
          "100",
          "--max-iterations",
          "3",
          "--export",
          "none",
          "--simulate",
          (dir / "six_steps.yaml").string(),
          "--out",
          out.string(),
          "-q"};
}

int count_errors(const std::string& err) {
  int n = 0;
  for (auto at = err.find("vim-pipeline: error:"); at != std::string::npos;
       at = err.find("vim-pipeline: error:", at + 1))
    ++n;
  return n;
}

}  // namespace

TEST(MpiFaults, SigkillOfTheWholeJobAtRandomMomentsLeavesOnlyCompleteFiles) {
  const auto dir = scratch_dir("faults_mpi", "sigkill");
  write_inputs(dir);
  const auto t0 = std::chrono::steady_clock::now();
  const ProcessResult full =
      wait_cli(spawn_process(mpirun_args(dir, dir / "full"), dir / "err.txt"), dir / "err.txt");
  const double duration = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(full.code, 0) << full.err;
  ASSERT_TRUE(fs::exists(dir / "full" / "steps" / "step_0006.pvtu"));
  ASSERT_TRUE(fs::exists(dir / "full" / "steps" / "step_0006_1.vtu"));
  for (const auto& f : final_files(dir / "full")) ASSERT_EQ(incomplete_reason(f), "") << f;

  std::mt19937 rng(3434);  // fixed seed: the same kill times at every run of the test
  std::uniform_real_distribution<double> moment(0.0, 1.1);
  long left = 0;
  for (int k = 0; k < 8; ++k) {
    const fs::path out = dir / ("killed" + std::to_string(k));
    // mpirun, the shells and both ranks at once
    const pid_t pid = spawn_process(mpirun_args(dir, out), dir / "err.txt");
    left += kill_and_count_complete_files(pid, moment(rng) * duration, duration, dir / "err.txt", out);
  }
  std::cout << "[ info ] run " << duration << " s; " << left << " final-named files left by 8 killed runs\n";
}

TEST(MpiFaults, FullDiskGivesOneErrorAndNoFinalNamedPartialFile) {
  const auto dir = scratch_dir("faults_mpi", "full_disk");
  write_inputs(dir);
  // Within the first step's pieces (about 4 KB each), within step 4's pieces (about 16 KB), and within
  // the first figure (deformed.png, about 54 KB).
  for (long limit : {3000L, 10000L, 20000L}) {
    SCOPED_TRACE("RLIMIT_FSIZE " + std::to_string(limit) + " bytes");
    const fs::path out = dir / ("out" + std::to_string(limit));
    const ProcessResult r =
        wait_cli(spawn_process(mpirun_args(dir, out, limit), dir / "err.txt"), dir / "err.txt");
    EXPECT_EQ(r.signal, 0) << "killed by signal " << r.signal;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(count_errors(r.err), 1) << r.err;  // mpirun adds its own banner about the failed rank
    EXPECT_NE(r.err.find("vim-pipeline: error: cannot write " + out.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(": File too large (is the disk full?)"), std::string::npos) << r.err;
    for (const auto& f : final_files(out)) EXPECT_EQ(incomplete_reason(f), "") << f;
  }
}

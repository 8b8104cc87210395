// Studies under mpirun through the real CLI (this program is not an MPI program: it starts `mpirun -np 2
// vim-pipeline ...`). Truth: the serial run of the same study; the two study.csv files agree cell by
// cell (numbers to 1e-8 relative), and each rank ran its own cases (case i on rank i mod 2).
#include <gtest/gtest.h>

#include <cmath>

#include "run_cli.hpp"
#include "run_on_ranks.hpp"
#include "study_inputs.hpp"

using vim::test::quote;
using vim::test::read_study_csv;
using vim::test::run_command;
using vim::test::run_on_ranks;
using vim::test::run_pipeline;
using vim::test::study_options;
namespace fs = std::filesystem;



TEST(StudyMpi, TwoRanksWriteTheSerialStudyTable) {
  vim::test::TempDir dir("study_mpi");
  vim::test::write_study_inputs(dir.path);
  std::ofstream(dir.path / "study.yaml") << "scenario: base.yaml\n"
                                            "cases:\n"
                                            "  - {name: straight}\n"
                                            "  - {name: tilted, direction: [1, 0.2, 0.1]}\n"
                                            "  - {name: too-deep, depth: 10.0}\n"
                                            "grid:\n"
                                            "  poisson_ratio: [0.2, 0.35]\n";
  const auto serial = run_pipeline(study_options(dir.path, "study.yaml", dir.path / "serial"));
  ASSERT_EQ(serial.code, 1) << serial.err;  // the too-deep cases fail
  const std::string options = study_options(dir.path, "study.yaml", dir.path / "two");
  const auto two =
      run_on_ranks(2, options.substr(0, options.find(" -q ")) + options.substr(options.find(" -q ") + 3));
  EXPECT_EQ(two.code, 1) << two.err;
  EXPECT_EQ(vim::test::count_lines(two.out), 1) << two.out;  // the summary, printed by rank 0 alone
  std::size_t errors = 0;
  for (std::size_t at = 0; (at = two.err.find("vim-pipeline: error:", at)) != std::string::npos; ++at)
    ++errors;
  EXPECT_EQ(errors, 1u) << two.err;
  // Case i (from 0) ran on rank i mod 2: rank 1 ran straight-g2, tilted-g2 and too-deep-g2.
  EXPECT_NE(two.err.find("case 'straight-g2' (1 of 3 on rank 1)"), std::string::npos) << two.err;
  EXPECT_NE(two.err.find("case 'tilted-g1' (2 of 3 on rank 0)"), std::string::npos) << two.err;

  const auto a = read_study_csv(dir.path / "serial" / "study.csv");
  const auto b = read_study_csv(dir.path / "two" / "study.csv");
  ASSERT_EQ(a.size(), 6u);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].size(), b[i].size());
    for (const auto& [column, cell] : a[i]) {
      const std::string& other = b[i].at(column);
      if (column == "case" || column == "status" || cell.empty()) {
        EXPECT_EQ(cell, other) << column;
      } else if (column == "message") {  // names the case's folder, which differs
        EXPECT_EQ(cell.substr(cell.find("case.yaml")), other.substr(other.find("case.yaml")));
      } else {
        const double x = std::stod(cell), y = std::stod(other);
        EXPECT_NEAR(x, y, 1e-8 * std::max(1.0, std::abs(x))) << a[i].at("case") << " " << column;
      }
    }
  }
  EXPECT_EQ(a[4].at("status"), "failed");
  EXPECT_EQ(a[0].at("status"), "done");
}

// Meshing alone (no --simulate, no --study) has nothing to spread over ranks: refused, once.
TEST(StudyMpi, MeshingAloneOnSeveralRanksIsRefusedOnce) {
  vim::test::TempDir dir("study_mpi_single");
  vim::test::write_study_inputs(dir.path);
  const auto r = run_on_ranks(2, quote(dir / "in.mha") + " --nodes 100 --out " + quote(dir / "out"));
  EXPECT_NE(r.code, 0);
  EXPECT_EQ(r.err.find("vim-pipeline: error:"), r.err.rfind("vim-pipeline: error:")) << r.err;  // once
  EXPECT_NE(r.err.find("vim-pipeline: error: started by mpirun on 2 processes: only a simulation"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir.path / "out"));
}

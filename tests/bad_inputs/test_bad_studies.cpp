// Bad study files through the CLI's main (in the test's process): each gives exit code 1, one `vim-pipeline:
// error:` line naming the study file, the line and the key (or the base scenario's own error), and no
// study.csv. Truth: the line and key of the mistake written into each file.
#include <gtest/gtest.h>

#include "cli_in_process.hpp"
#include "study_inputs.hpp"

using vim::test::run_pipeline_in_process;
namespace fs = std::filesystem;

TEST(BadStudies, OneLineErrorNamingFileLineAndKey) {
  vim::test::TempDir dir("bad_study");
  vim::test::write_study_inputs(dir.path);
  std::ofstream(dir.path / "needles.yaml")
      << "boundary_conditions: [{type: fixed, region: {box_face: x_max}}]\n"
         "needles:\n  - {name: a, entry: [0, 1, 1], direction: [1, 0, 0], "
         "depth: 1, steps: 2, diameter: 0.2, friction: {model: stick}}\n";
  struct Bad {
    std::string yaml, expected;
  };
  const std::vector<Bad> bad = {
      {"scenario: base.yaml\ngrid: {dept: [1]}\n",
       "study.yaml:2: unknown key 'grid.dept'; valid keys of grid: entry"},
      {"scenario: base.yaml\ncases:\n  - {name: a}\n  - {name: b,\n     poisson_ratio: 0.6}\n",
       "study.yaml:5: case 'b' (poisson_ratio = 0.6): material.poisson_ratio = 0.6 is not valid"},
      {"scenario: base.yaml\ngrid:\n  depth: [1.0, -2.0]\n",
       "study.yaml:3: case 'g2' (depth = -2.0): needle.depth must be > 0"},
      {"scenario: base.yaml\ncases:\n  - {name: a}\n  - {name: a}\n",
       "study.yaml:4: cases[1].name = 'a' is given to two cases"},
      {"cases: [{name: a}]\n", "study.yaml:1: missing key 'scenario'"},
      {"scenario: missing.yaml\ncases: [{name: a}]\n",
       "study.yaml:1: scenario: cannot open the base scenario"},
      {"scenario: base.yaml\n", "study.yaml:1: missing key 'cases' or 'grid'"},
      {"scenario: base.yaml\ngrid: {depth: []}\n",
       "study.yaml:2: grid.depth must be a non-empty list of values"},
      {"scenario: base.yaml\ncases: [{depth: 1}]\ngrid: {depth: [2]}\n",
       "study.yaml:2: case 'case-1': depth is also varied by grid (line 3)"},
      {"scenario: base.yaml\ngrid: {entry: [[1, 2]]}\n",
       "study.yaml:2: grid.entry[0] must be a list of 3 numbers"},
      {"scenario: base.yaml\ngrid:\n  scale: [1, x]\n",
       "study.yaml:3: grid.scale[1] must be a number, got 'x'"},
      {"scenario: base.yaml\ncases: [{name: 'a b'}]\n",
       "study.yaml:2: cases[0].name = 'a b' must be a folder name"},
      {"scenario: needles.yaml\ngrid: {depth: [1]}\n", "study.yaml:2: depth varies the needle, but"},
      {"scenario: base.yaml\ncases: [{name: a]\n", "study.yaml:2: YAML syntax error"},
  };
  for (const Bad& b : bad) {
    std::ofstream(dir.path / "study.yaml") << b.yaml;
    const fs::path out = dir.path / "out";
    const auto r = run_pipeline_in_process(vim::test::study_options(dir.path, "study.yaml", out));
    EXPECT_EQ(r.code, 1) << b.yaml;
    EXPECT_EQ(vim::test::count_lines(r.err), 1) << b.yaml << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(b.expected), std::string::npos) << b.yaml << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out / "study.csv")) << b.yaml;
  }
}

// Test inputs of a study through the CLI: a small table1 phantom (a sphere of 2.0 in 1.0 on a 3 mm cube,
// 12³ voxels), a base needle scenario on it, and study.csv read back by column name.
#pragma once

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>

#include "run_cli.hpp"

namespace vim::test {

// Writes in.mha and base.yaml into `dir`: a stuck needle from the x_min face along x, x_max held.
inline void write_study_inputs(const std::filesystem::path& dir) {
  vim::pipeline::write_image(vim::pipeline::phantoms::table1(12), (dir / "in.mha").string());
  std::ofstream f(dir / "base.yaml");
  f << "units: {length: mm, modulus: kPa}\n"
       "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
       "boundary_conditions:\n"
       "  - {type: fixed, region: {box_face: x_max}}\n"
       "needle:\n"
       "  entry: [0, 1.5, 1.5]\n"
       "  direction: [1, 0, 0]\n"
       "  depth: 1.5\n"
       "  steps: 3\n"
       "  diameter: 0.2\n"
       "  model: kinematic\n"
       "  friction: {model: stick}\n"
       "targets:\n"
       "  - {name: ahead, position: [2.2, 1.5, 1.5]}\n"
       "output: {every: 3}\n";
}

// The options of every study run of the tests (a coarse VIM mesh, no exports).
inline std::string study_options(const std::filesystem::path& dir, const std::string& study,
                                 const std::filesystem::path& out) {
  return quote((dir / "in.mha").string()) + " --nodes 100 --max-iterations 3 --export none -q --study " +
         quote((dir / study).string()) + " --out " + quote(out.string());
}

// study.csv as rows of column name → cell (a quoted message may hold commas).
inline std::vector<std::map<std::string, std::string>> read_study_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (char c : line) {
      if (c == '"')
        quoted = !quoted;
      else if (c == ',' && !quoted)
        cells.push_back(std::move(cell)), cell.clear();
      else
        cell += c;
    }
    cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

}  // namespace vim::test

// A measured force–depth curve from CSV (force_fit.hpp).
#include <cmath>
#include <fstream>
#include <sstream>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/fit/force_fit.hpp>

namespace vim::pipeline {

namespace {

std::vector<std::string> split_row(const std::string& row) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(row);
  while (std::getline(in, cell, ',')) {
    const auto b = cell.find_first_not_of(" \t\r\"");
    const auto e = cell.find_last_not_of(" \t\r\"");
    cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
  }
  if (!row.empty() && row.back() == ',') cells.emplace_back();
  return cells;
}

bool blank(const std::string& row) { return row.find_first_not_of(" \t\r") == std::string::npos; }

}  // namespace

MeasuredCurve parse_measured_forces(const std::string& text, const std::string& source) {
  MeasuredCurve m;
  m.source = source;
  std::istringstream in(text);
  std::string row;
  int line = 0;
  long depth_col = -1, force_col = -1;
  std::vector<std::string> header;
  while (std::getline(in, row)) {
    ++line;
    if (blank(row)) continue;
    if (header.empty()) {
      header = split_row(row);
      for (std::size_t c = 0; c < header.size(); ++c) {
        if (header[c] == "depth") depth_col = static_cast<long>(c);
        if (header[c] == "force") force_col = static_cast<long>(c);
      }
      if (depth_col < 0 || force_col < 0)
        throw InputError(source + ":" + std::to_string(line) +
                         ": the header must name the columns 'depth' and '" +
                         "force' (in the scenario's units; other columns are ignored), got '" + row + "'");
      continue;
    }
    const std::vector<std::string> cells = split_row(row);
    double value[2] = {0.0, 0.0};
    const long cols[2] = {depth_col, force_col};
    for (int k = 0; k < 2; ++k) {
      const char* name = k == 0 ? "depth" : "force";
      const std::string cell = static_cast<std::size_t>(cols[k]) < cells.size() ? cells[cols[k]] : "";
      std::size_t used = 0;
      try {
        value[k] = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (cell.empty() || used != cell.size() || !std::isfinite(value[k]))
        throw InputError(source + ":" + std::to_string(line) + ": column '" + name +
                         "' must be a number, got '" + cell + "'");
    }
    if (!m.depth.empty() && !(value[0] > m.depth.back()))
      throw InputError(source + ":" + std::to_string(line) +
                       ": column 'depth' must increase from row to row, got " + cells[depth_col] + " after " +
                       std::to_string(m.depth.back()));
    m.depth.push_back(value[0]);
    m.force.push_back(value[1]);
    m.line.push_back(line);
  }
  if (header.empty())
    throw InputError(source +
                     ": the file is empty; give a header naming 'depth' and 'force' and one row per "
                     "measured depth");
  if (m.depth.empty()) throw InputError(source + ": no rows after the header (one row per measured depth)");
  return m;
}

MeasuredCurve read_measured_forces(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the measured force file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_measured_forces(ss.str(), path);
}

}  // namespace vim::pipeline

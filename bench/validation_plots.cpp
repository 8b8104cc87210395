// Validation plots (docs/figures/validation_*.png) from the tables the validation programs print:
// markdown tables of bench_fem_validate (headers with "relL2 grid" / "relL2 VIM", identified by the
// last heading: "sphere compression", "two-inclusion") and the Table I rows, either the markdown
// table of docs/validation.md ("| method | nodes | ... | TF% |") or bench/table1's text output
// (grid / VIM / VIM(paper) lines). Later files override earlier ones for the same node count.
//
//   validation_plots OUTDIR FILE...
// Writes, when the data is present (line colours: series_color(k) of png.hpp):
//   validation_sphere.png, validation_inclusions_2d.png: relL2 vs nodes, blue = VIM, red = grid;
//   validation_table1_tf.png: TF% vs nodes, blue = VIM (ours), red = VIM (paper), green = grid.
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <vim/pipeline/output/figures.hpp>

namespace {

std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line.substr(1));
  std::string c;
  while (std::getline(ss, c, '|')) {
    std::string t;
    for (char ch : c)
      if (ch != '*' && ch != '%') t += ch;
    const auto a = t.find_first_not_of(' '), b = t.find_last_not_of(' ');
    out.push_back(a == std::string::npos ? "" : t.substr(a, b - a + 1));
  }
  return out;
}

double number(const std::string& s) {
  try {
    std::size_t pos = 0;
    const double v = std::stod(s, &pos);
    return v;
  } catch (...) {
    return NAN;
  }
}

bool has(const std::string& s, const char* what) { return s.find(what) != std::string::npos; }

struct Curve {
  std::map<double, double> vim, grid, paper;
};

void write(const std::filesystem::path& path, const std::vector<const std::map<double, double>*>& series,
           const std::vector<std::string>& names, const std::string& y_label) {
  std::map<double, bool> xs;
  for (const auto* s : series)
    for (const auto& [x, y] : *s) xs[x] = true;
  if (xs.empty()) return;
  std::vector<double> x;
  std::vector<std::vector<double>> ys(series.size());
  for (const auto& [v, b] : xs) {
    x.push_back(v);
    for (std::size_t k = 0; k < series.size(); ++k) {
      const auto it = series[k]->find(v);
      ys[k].push_back(it == series[k]->end() ? NAN : it->second);
    }
  }
  const auto info = vim::pipeline::write_line_plot(path, x, ys, names, "nodes", y_label);
  std::printf("wrote %s (%zu node counts; x axis %s, y axis %s)\n", path.c_str(), x.size(),
              info["x_range"].dump().c_str(), info["y_range"].dump().c_str());
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 3) {
    std::fprintf(stderr, "usage: validation_plots OUTDIR FILE...\n");
    return 2;
  }
  std::map<std::string, Curve> curves;  // "sphere", "inclusions", "table1"
  for (int f = 2; f < argc; ++f) {
    std::ifstream in(argv[f]);
    if (!in) throw std::runtime_error(std::string("cannot read ") + argv[f]);
    std::string line, heading, table;
    std::map<std::string, std::size_t> col;
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] == '#') {
        heading = line, table.clear();
        continue;
      }
      if (line.rfind("|", 0) == 0) {
        const auto c = cells(line);
        if (has(line, "relL2 grid") && has(line, "relL2 VIM") && !has(line, "gland")) {
          table = has(heading, "phere compression") ? "sphere"
                  : has(heading, "two-inclusion")   ? "inclusions"
                                                    : "";
          col.clear();
          for (std::size_t k = 0; k < c.size(); ++k) col[c[k]] = k;
          continue;
        }
        if (has(line, "method") && has(line, "TF") && has(line, "nodes")) {
          table = "table1md";
          col.clear();
          for (std::size_t k = 0; k < c.size(); ++k) col[c[k]] = k;
          continue;
        }
        if (has(line, "nodes")) {  // another table's header: not plotted
          table.clear();
          continue;
        }
        if (table.empty() || c.empty() || !col.count("nodes") || col["nodes"] >= c.size()) continue;
        const double nodes = number(c[col["nodes"]]);
        if (!std::isfinite(nodes)) continue;
        if (table == "table1md") {
          if (!col.count("TF") || col["TF"] >= c.size()) continue;
          // the "TF%" header loses its '%' in cells(): both TF and TF% read "TF"; the last one is TF%.
          const double tf = number(c[col["TF"]]);
          Curve& t = curves["table1"];
          const std::string m = c[0];
          if (has(m, "paper"))
            t.paper[nodes] = tf;
          else if (has(m, "ours"))
            t.vim[nodes] = tf;
          else if (has(m, "grid"))
            t.grid[nodes] = tf;
        } else if (col.count("relL2 grid") && col.count("relL2 VIM") && col["relL2 grid"] < c.size() &&
                   col["relL2 VIM"] < c.size()) {
          Curve& t = curves[table];
          t.grid[nodes] = number(c[col["relL2 grid"]]);
          t.vim[nodes] = number(c[col["relL2 VIM"]]);
        }
        continue;
      }
      // bench/table1 text rows: method nodes elements minNRR minDA maxDA FN FP TF TF% seconds iters
      std::stringstream ss(line);
      std::vector<std::string> tok;
      for (std::string t; ss >> t;) tok.push_back(t);
      if (tok.size() >= 10 && (tok[0] == "grid" || tok[0] == "VIM" || tok[0] == "VIM(paper)") &&
          tok[9].back() == '%') {
        const double nodes = number(tok[1]), tf = number(tok[9].substr(0, tok[9].size() - 1));
        Curve& t = curves["table1"];
        (tok[0] == "grid" ? t.grid : tok[0] == "VIM" ? t.vim : t.paper)[nodes] = tf;
      }
    }
  }
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  const std::string rel_l2 = "relative L2 displacement error vs the voxel reference";
  if (curves.count("sphere"))
    write(dir / "validation_sphere.png", {&curves["sphere"].vim, &curves["sphere"].grid}, {"VIM", "grid"},
          rel_l2);
  if (curves.count("inclusions"))
    write(dir / "validation_inclusions_2d.png", {&curves["inclusions"].vim, &curves["inclusions"].grid},
          {"VIM", "grid"}, rel_l2);
  if (curves.count("table1"))
    write(dir / "validation_table1_tf.png",
          {&curves["table1"].vim, &curves["table1"].paper, &curves["table1"].grid},
          {"VIM (ours)", "VIM (paper)", "grid"}, "misclassified voxels TF [%]");
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "validation_plots: %s\n", e.what());
  return 1;
}

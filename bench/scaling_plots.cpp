// Scaling plots from the "ROW ..." lines of bench_mesher_scaling (collected by
// bench/scaling.sh). Both axes are log10, so a straight line of slope p means cost ∝ x^p.
//
//   scaling_plots OUTDIR ROWS-FILE
// Writes (line colours: series_color(k) of png.hpp, k in increasing order of the series key):
//   scaling_vs_voxels.png:   log10(s/iteration) vs log10(voxels), one series per node budget;
//   scaling_vs_elements.png: log10(s/iteration) vs log10(elements), one series per image size.
// ROW n voxels nodes elements setup_s iter_mean_s iterations converged vmhwm_MB cpu_per_wall
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>
#include <vim/pipeline/output/figures.hpp>

namespace {

using Series = std::map<long, std::map<double, double>>;  // key -> (log10 x -> log10 s/iteration)

void write(const std::filesystem::path& path, const Series& series, const char* key_name,
           const char* x_name) {
  std::set<double> xs;
  for (const auto& [key, s] : series)
    for (const auto& [x, y] : s) xs.insert(x);
  if (xs.empty()) return;
  const std::vector<double> x(xs.begin(), xs.end());
  std::vector<std::vector<double>> ys;
  std::vector<std::string> names;
  for (const auto& [key, s] : series) {
    std::vector<double> y;
    for (double v : x) {
      const auto it = s.find(v);
      y.push_back(it == s.end() ? NAN : it->second);
    }
    ys.push_back(y);
    names.push_back(std::string(key_name) + " " + std::to_string(key));
  }
  const auto info = vim::pipeline::write_line_plot(path, x, ys, names, std::string("log10 ") + x_name,
                                                   "log10 seconds per iteration");
  std::printf("wrote %s: x = log10 %s, y = log10 s/iteration, x axis %s, y axis %s, series %s\n",
              path.c_str(), x_name, info["x_range"].dump().c_str(), info["y_range"].dump().c_str(),
              info["series"].dump().c_str());
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc != 3) {
    std::fprintf(stderr, "usage: scaling_plots OUTDIR ROWS-FILE\n");
    return 2;
  }
  std::ifstream in(argv[2]);
  if (!in) throw std::runtime_error(std::string("cannot read ") + argv[2]);
  Series by_budget, by_image;  // vs voxels (key: nodes), vs elements (key: n)
  std::string line;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string tag;
    long n = 0, nodes = 0, elements = 0;
    double voxels = 0, setup = 0, iter = 0;
    if (!(ss >> tag >> n >> voxels >> nodes >> elements >> setup >> iter) || tag != "ROW" || !(iter > 0))
      continue;
    by_budget[nodes][std::log10(voxels)] = std::log10(iter);
    by_image[n][std::log10(static_cast<double>(elements))] = std::log10(iter);
  }
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  write(dir / "scaling_vs_voxels.png", by_budget, "nodes", "voxels");
  write(dir / "scaling_vs_elements.png", by_image, "n", "elements");
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "scaling_plots: %s\n", e.what());
  return 1;
}

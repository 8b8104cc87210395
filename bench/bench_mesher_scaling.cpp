// Scaling study (docs/performance.md): the Table I sphere phantom (cube [0,3]³, sphere r = 1, 2.0 in / 1.0 out)
// sampled at n³ voxels, meshed by VIM from the regular Kuhn grid closest to a node budget (default
// options: λ = 0.5, 150° bound, convergence 1e-3). Prints, per run, the set-up time (grid mesh +
// optimize()'s own set-up: prefix sums, per-element caches, colouring = history[0].seconds), the
// seconds of each iteration, the mean of the first 3 iterations, the iterations run, whether Eq. 9
// converged, and the peak memory VmHWM of this process (from /proc/self/status).
//
//   bench_mesher_scaling --n N --nodes B [--max-iterations M] [--threads T]
//
// One (image, budget) pair per process, so VmHWM belongs to that pair only; bench/scaling.sh loops.
// The last line is machine-readable:
//   ROW n voxels nodes elements setup_s iter_mean_s iterations converged vmhwm_MB cpu_per_wall
#include "metrics.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/vim.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <fstream>
#include <stdexcept>
#include <string>

namespace {

// Peak resident set (VmHWM) of this process in MB, or -1 if /proc is unavailable.
double vmhwm_mb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;  // kB
  return -1.0;
}

// FNV-1a over the bytes of the final node coordinates and cells: equal hashes = bit-identical meshes
// (compare builds before/after an optimisation of the mesher).
std::uint64_t mesh_hash(const vim::SimplexMesh<3>& mesh) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) h = (h ^ p[k]) * 1099511628211ull;
  };
  for (const auto& p : mesh.points) mix(p.data(), 3 * sizeof(double));
  for (const auto& c : mesh.cells) mix(c.data(), sizeof(c[0]) * c.size());
  return h;
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) try {
  long n = 64, budget = 1000;
  vim::VimOptions options;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--n")) n = std::atol(value("--n"));
    else if (!std::strcmp(argv[i], "--nodes")) budget = std::atol(value("--nodes"));
    else if (!std::strcmp(argv[i], "--max-iterations")) options.max_iterations = std::atoi(value("--max-iterations"));
    else if (!std::strcmp(argv[i], "--threads")) options.threads = std::atoi(value("--threads"));
    else throw std::invalid_argument(std::string("unknown argument ") + argv[i]);
  }
  options.validate();

  auto t0 = std::chrono::steady_clock::now();
  const vim::Image<3> image = vim::metrics::table1_phantom(n);
  const double t_image = since(t0);
  t0 = std::chrono::steady_clock::now();
  const auto axis = vim::nodes_per_axis_for_budget<3>(image.box_min(), image.box_max(), budget);
  vim::SimplexMesh<3> grid = vim::regular_grid_mesh<3>(image.box_min(), image.box_max(), axis);
  const double t_grid = since(t0);
  const std::size_t nodes = grid.n_points(), cells = grid.n_cells();
  const double voxels = static_cast<double>(image.voxel_count());
  std::printf("phantom %ld^3 (%.2fs), budget %ld -> %zu nodes, %zu elements (%.1f voxels/element, edge ~%.1f voxels), "
              "grid %.3fs\n",
              n, t_image, budget, nodes, cells, voxels / static_cast<double>(cells),
              static_cast<double>(n) / (axis[0] - 1), t_grid);
  std::fflush(stdout);

  const std::clock_t c0 = std::clock();
  t0 = std::chrono::steady_clock::now();
  const auto r = vim::optimize<3>(image, std::move(grid), options, [](const vim::IterationRecord& rec) {
    std::printf("  iteration %2d: %9.3f s  E %.6f  v %.3e  moves %ld  swaps %ld  VmHWM %.0f MB\n", rec.iteration,
                rec.seconds, rec.energy, rec.v, rec.moves, rec.swaps, vmhwm_mb());
    std::fflush(stdout);
  });
  const double total = since(t0);
  const double cpu_per_wall = (static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC) / total;
  const int iterations = static_cast<int>(r.history.size()) - 1;
  double mean = 0.0;
  const int k = std::min(iterations, 3);
  for (int i = 1; i <= k; ++i) mean += r.history[i].seconds;
  mean = k > 0 ? mean / k : 0.0;
  const double setup = t_grid + r.history[0].seconds;
  std::printf("total %.2fs, set-up %.3fs, mean of first %d iterations %.3fs, %d iterations, %s, final %zu elements, "
              "CPU/wall %.2f\n",
              total, setup, k, mean, iterations, r.converged ? "converged" : "NOT converged", r.mesh.n_cells(),
              cpu_per_wall);
  std::printf("final E %.17g, mesh hash %016llx\n", r.history.back().energy,
              static_cast<unsigned long long>(mesh_hash(r.mesh)));
  std::printf("ROW %ld %.0f %zu %zu %.3f %.3f %d %d %.1f %.2f\n", n, voxels, nodes, cells, setup, mean, iterations,
              r.converged ? 1 : 0, vmhwm_mb(), cpu_per_wall);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_mesher_scaling: %s\n", e.what());
  return 1;
}

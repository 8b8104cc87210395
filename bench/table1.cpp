// Paper Table I reproduced (docs/validation.md): the 100³ sphere phantom meshed by the regular Kuhn grid and
// by VIM at 125, 343 and 4096 nodes; quality (min NRR, min/max dihedral) and the FN/FP/TF voxel
// counts of the thresholded sphere (§VI-B), computed by the independent code in metrics.hpp,
// printed beside the paper's VIM rows.
//
//   table1 [--n 100] [--lambda 0.5] [--max-iterations 50] [--convergence 1e-3] [--threads 0]
//          [--line-search-step 0.5] [--search-width 3] [--random-walk SAMPLES] [--max-dihedral 150]
//          [--min-dihedral 0] [--min-rr 0] [--verbose] [nodes ...]
// --verbose prints one line per iteration (E, v of Eq. 9, moves, swaps, seconds: all, node updates, swaps) to stderr.
#include "metrics.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/vim.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <string>
#include <vector>

namespace {

struct PaperRow {
  long nodes, elements;
  double nrr, min_da, max_da;
  long fn, fp, tf;
  double tf_percent;
};
const std::map<long, PaperRow> kPaperVim = {
    {125, {125, 387, 0.40437, 19.4780, 146.035, 2921, 5643, 8564, 5.52}},
    {343, {343, 1334, 0.14745, 11.8827, 149.986, 1279, 2818, 4097, 2.64}},
    {4096, {4096, 20790, 0.20894, 10.6295, 149.986, 520, 684, 1204, 0.78}},
};

void print_header() {
  std::printf("%-10s %6s %8s %8s %8s %8s %7s %7s %7s %7s %9s %9s\n", "method", "nodes", "elements", "minNRR",
              "minDA", "maxDA", "FN", "FP", "TF", "TF%", "seconds", "iters");
}

void print_row(const char* method, const vim::SimplexMesh<3>& mesh, const vim::metrics::SphereMetrics& m,
               double seconds, int iterations) {
  const auto q = vim::metrics::quality<3>(mesh);
  std::printf("%-10s %6zu %8zu %8.5f %8.4f %8.3f %7ld %7ld %7ld %6.2f%% %9.2f %9d\n", method, mesh.n_points(),
              mesh.n_cells(), q.min_nrr, q.min_angle, q.max_angle, m.fn, m.fp, m.tf, m.tf_percent, seconds,
              iterations);
}

}  // namespace

int main(int argc, char** argv) try {
  long n = 100;
  vim::VimOptions options;
  bool verbose = false;
  std::vector<long> budgets;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--n")) n = std::atol(value("--n"));
    else if (!std::strcmp(argv[i], "--lambda")) options.lambda = std::atof(value("--lambda"));
    else if (!std::strcmp(argv[i], "--max-iterations")) options.max_iterations = std::atoi(value("--max-iterations"));
    else if (!std::strcmp(argv[i], "--convergence")) options.convergence = std::atof(value("--convergence"));
    else if (!std::strcmp(argv[i], "--threads")) options.threads = std::atoi(value("--threads"));
    else if (!std::strcmp(argv[i], "--line-search-step")) options.line_search_step = std::atof(value("--line-search-step"));
    else if (!std::strcmp(argv[i], "--random-walk")) {
      options.strategy = vim::VimOptions::NodeStrategy::random_walk;
      options.random_walk_samples = std::atoi(value("--random-walk"));
    }
    else if (!std::strcmp(argv[i], "--search-width")) options.search_width = std::atoi(value("--search-width"));
    else if (!std::strcmp(argv[i], "--max-dihedral")) options.max_dihedral_deg = std::atof(value("--max-dihedral"));
    else if (!std::strcmp(argv[i], "--min-dihedral")) options.min_dihedral_deg = std::atof(value("--min-dihedral"));
    else if (!std::strcmp(argv[i], "--min-rr")) options.min_radius_ratio = std::atof(value("--min-rr"));
    else if (!std::strcmp(argv[i], "--verbose")) verbose = true;
    else budgets.push_back(std::atol(argv[i]));
  }
  if (budgets.empty()) budgets = {125, 343, 4096};
  options.validate();

  const vim::Image<3> image = vim::metrics::table1_phantom(n);
  const Eigen::Vector3d centre(1.5, 1.5, 1.5), lo = image.box_min(), hi = image.box_max();
  std::printf("Table I phantom: %ld^3 voxels, cube [0,3]^3, sphere r=1 (2.0 in / 1.0 out); lambda=%g, convergence=%g\n",
              n, options.lambda, options.convergence);
  if (options.max_dihedral_deg != 150.0 || options.min_dihedral_deg > 0.0 || options.min_radius_ratio > 0.0)
    std::printf("quality bound: max dihedral %g, min dihedral %g, min NRR %g\n", options.max_dihedral_deg,
                options.min_dihedral_deg, options.min_radius_ratio);
  print_header();
  for (long budget : budgets) {
    const auto axis = vim::nodes_per_axis_for_budget<3>(lo, hi, budget);
    const vim::SimplexMesh<3> grid = vim::regular_grid_mesh<3>(lo, hi, axis);
    const auto gm = vim::metrics::table1_metrics<3>(image, grid, centre, 1.0);
    print_row("grid", grid, gm, 0.0, 0);

    const auto t0 = std::chrono::steady_clock::now();
    vim::ProgressCallback progress;
    if (verbose)
      progress = [](const vim::IterationRecord& h) {
        std::fprintf(stderr, "  iteration %2d  E %.9f  v %.3e  searched %6ld  evaluations %8ld  moves %6ld  swaps %5ld  %.3f s (nodes %.3f, swaps %.3f)\n",
                     h.iteration, h.energy, h.v, h.searched, h.evaluations, h.moves, h.swaps, h.seconds, h.node_seconds,
                     h.swap_seconds);
      };
    const vim::VimResult<3> r = vim::optimize<3>(image, grid, options, progress);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto vm = vim::metrics::table1_metrics<3>(image, r.mesh, centre, 1.0);
    print_row("VIM", r.mesh, vm, seconds, static_cast<int>(r.history.size()) - 1);

    auto it = kPaperVim.find(budget);
    if (it != kPaperVim.end()) {
      const PaperRow& p = it->second;
      std::printf("%-10s %6ld %8ld %8.5f %8.4f %8.3f %7ld %7ld %7ld %6.2f%% %9s %9s\n", "VIM(paper)", p.nodes,
                  p.elements, p.nrr, p.min_da, p.max_da, p.fn, p.fp, p.tf, p.tf_percent, "-", "-");
      std::printf("%-10s TF%% ratio ours/paper = %.3f, VIM/grid = %.3f, sphere voxels = %ld%s\n", "", 
                  vm.tf_percent / p.tf_percent, gm.tf > 0 ? double(vm.tf) / double(gm.tf) : 0.0, vm.sphere_voxels,
                  vm.tf_percent <= p.tf_percent ? "  [<= paper]" : "  [ABOVE paper]");
    }
    std::fflush(stdout);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "table1: %s\n", e.what());
  return 1;
}

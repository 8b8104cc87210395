// VIM vs CGAL Mesh_3 on the same image at (about) the same node count, in one run.
// The 100³ Table I phantom (cube [0,3]³, sphere r=1, 2 inside / 1 outside) is meshed by VIM at a
// node budget (default 4096, default VimOptions as table1) and by CGAL Mesh_3 from a labeled
// Image_3 built in memory from the same voxels (label 1 = background, 2 = sphere; CGAL meshes only
// non-zero labels, so both subdomains are meshed and the mesh covers the image box). CGAL's size
// parameter s (facet_size = cell_size = s, facet_distance = s/4) is tuned by a few refinement-only
// runs (no optimisers) to land within ±10% of VIM's node count; then two full runs are timed:
//   CGAL-pe  : refinement + perturb + exude (make_mesh_3 defaults);
//   CGAL-ol  : refinement + ODT + Lloyd (+ perturb + exude, as CGAL recommends after them).
// All three meshes are scored by the SAME independent code (bench/metrics.hpp, as table1): the
// object is the largest face-connected set of elements whose brute-force voxel mean > 1.5 (the VIM
// rule), TF% against the analytic sphere; quality = min NRR, min/max dihedral. For CGAL the
// subdomain-2 rule is printed as well (TF% of the tets CGAL labelled 2).
//
// VIM runs twice: with the default (screened) node update and with every direction searched in
// full (--search-width 0, row "VIM-full"); the ratio column is against the first. --threads 1 runs VIM
// sequential, as CGAL is here.
//
// Row "VIM-early": VIM stopped after the fewest iterations whose mesh already has the paper's Table I
// TF% at the budget (125 / 343 / 4096 nodes), not converged; printed for information next to CGAL-pe.
//
// --match-tf adds an equal-accuracy row "CGAL-pe@TF": s is bisected on refinement-only runs until
// CGAL's TF% (same metric) is at most VIM's, then that s is timed with perturb + exude; its node
// count is whatever that takes.
//
// --repeat R (default 3): the VIM, CGAL-pe and CGAL-ol rows are timed R times each and the fastest is
// reported, with the slowest, so that one slow run on a shared machine does not decide a ratio. VIM
// gives the same mesh every time (checked); CGAL's domain is seeded, but its meshes still differ a
// little from run to run (a few dozen elements), so the rows score its first run's mesh.
//
//   bench_cgal_mesh3 [--n 100] [--nodes 4096] [--threads 0] [--search-width 3] [--max-tuning 8] [--match-tf]
//                    [--repeat 3]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/vim.hpp>

#include "../metrics.hpp"
#include "cgal_mesh3.hpp"

namespace {

using namespace vim::cgal_bench;

void print_header() {
  std::printf("%-10s %6s %8s %8s %8s %8s %7s %7s %7s %7s %9s %9s\n", "method", "nodes", "elements", "minNRR",
              "minDA", "maxDA", "FN", "FP", "TF", "TF%", "seconds", "VIM/this");
}

void print_row(const char* method, const vim::SimplexMesh<3>& mesh, const vim::metrics::SphereMetrics& m,
               double seconds, double vim_seconds) {
  const auto q = vim::metrics::quality<3>(mesh);
  std::printf("%-10s %6zu %8zu %8.5f %8.4f %8.3f %7ld %7ld %7ld %6.2f%% %9.2f %9.3f\n", method,
              mesh.n_points(), mesh.n_cells(), q.min_nrr, q.min_angle, q.max_angle, m.fn, m.fp, m.tf,
              m.tf_percent, seconds, vim_seconds / seconds);
}

}  // namespace

int main(int argc, char** argv) try {
  long n = 100, budget = 4096;
  int max_tuning = 8, repeat = 3;
  bool match_tf = false;
  vim::VimOptions options;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--n"))
      n = std::atol(value("--n"));
    else if (!std::strcmp(argv[i], "--nodes"))
      budget = std::atol(value("--nodes"));
    else if (!std::strcmp(argv[i], "--threads"))
      options.threads = std::atoi(value("--threads"));
    else if (!std::strcmp(argv[i], "--search-width"))
      options.search_width = std::atoi(value("--search-width"));
    else if (!std::strcmp(argv[i], "--match-tf"))
      match_tf = true;
    else if (!std::strcmp(argv[i], "--max-tuning"))
      max_tuning = std::atoi(value("--max-tuning"));
    else if (!std::strcmp(argv[i], "--repeat"))
      repeat = std::max(1, std::atoi(value("--repeat")));
    else
      throw std::invalid_argument(std::string("unknown argument ") + argv[i]);
  }
  options.validate();

  const vim::Image<3> image = vim::metrics::table1_phantom(n);
  const Eigen::Vector3d centre(1.5, 1.5, 1.5), lo = image.box_min(), hi = image.box_max();
  std::printf(
      "VIM vs CGAL %d.%d Mesh_3: Table I phantom %ld^3 voxels, cube [0,3]^3, sphere r=1; target %ld nodes\n",
      CGAL_VERSION_MAJOR, CGAL_VERSION_MINOR, n, budget);
  std::printf("object rule (all rows): largest face-connected set of elements with voxel mean > 1.5\n");
  std::fflush(stdout);

  // VIM, default options, from the regular Kuhn grid at the budget (as table1).
  const auto axis = vim::nodes_per_axis_for_budget<3>(lo, hi, budget);
  const vim::SimplexMesh<3> grid = vim::regular_grid_mesh<3>(lo, hi, axis);
  auto t0 = std::chrono::steady_clock::now();
  const vim::VimResult<3> r = vim::optimize<3>(image, grid, options);
  double vim_seconds = seconds_since(t0), vim_slowest = vim_seconds;
  for (int k = 1; k < repeat; ++k) {
    t0 = std::chrono::steady_clock::now();
    const vim::VimResult<3> again = vim::optimize<3>(image, grid, options);
    const double sec = seconds_since(t0);
    if (again.mesh.cells != r.mesh.cells || again.mesh.points != r.mesh.points)
      throw std::runtime_error("VIM gave a different mesh on repeat " + std::to_string(k));
    vim_seconds = std::min(vim_seconds, sec);
    vim_slowest = std::max(vim_slowest, sec);
  }
  const auto vm = vim::metrics::table1_metrics<3>(image, r.mesh, centre, 1.0);
  const long target = static_cast<long>(r.mesh.n_points());
  std::printf(
      "VIM done: %zu nodes, %zu elements, %.2f s (fastest of %d, slowest %.2f s), %zu iterations (search "
      "width %d, "
      "threads %d)\n",
      r.mesh.n_points(), r.mesh.n_cells(), vim_seconds, repeat, vim_slowest, r.history.size() - 1,
      options.search_width, options.threads);
  // Where VIM's time goes: the set-up (history[0]), the node updates (parallel) and the swap passes
  // with their recolouring (sequential).
  double node_seconds = 0.0, swap_seconds = 0.0;
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    node_seconds += r.history[i].node_seconds;
    swap_seconds += r.history[i].swap_seconds;
  }
  const double setup_seconds = r.history[0].seconds;
  std::printf("VIM phases: set-up %.3f s, node updates %.3f s, swap passes %.3f s (sequential)\n",
              setup_seconds, node_seconds, swap_seconds);
  std::fflush(stdout);
  vim::VimOptions full_options = options;
  full_options.search_width = 0;
  t0 = std::chrono::steady_clock::now();
  const vim::VimResult<3> full = vim::optimize<3>(image, grid, full_options);
  const double full_seconds = seconds_since(t0);
  std::printf("VIM-full done: %zu nodes, %zu elements, %.2f s, %zu iterations (search width 0)\n",
              full.mesh.n_points(), full.mesh.n_cells(), full_seconds, full.history.size() - 1);
  std::fflush(stdout);

  // VIM stopped early: the fewest iterations whose mesh already has the paper's Table I TF% at this
  // budget (125 / 343 / 4096 nodes: 5.52 / 2.64 / 0.78%), timed as the fastest of `repeat`. It is not
  // converged (Eq. 9), so it does not count for the target; it shows the time VIM needs for the paper's
  // accuracy at equal nodes.
  const std::map<long, double> paper_tf = {{125, 5.52}, {343, 2.64}, {4096, 0.78}};
  vim::VimResult<3> early;
  double early_seconds = 0.0;
  int early_iterations = 0;
  if (const auto p = paper_tf.find(budget); p != paper_tf.end()) {
    for (int k = 1; k < static_cast<int>(r.history.size()) && early_iterations == 0; ++k) {
      vim::VimOptions early_options = options;
      early_options.max_iterations = k;
      early_seconds = std::numeric_limits<double>::infinity();
      for (int rep = 0; rep < repeat; ++rep) {  // VIM is deterministic: the first run's mesh decides
        t0 = std::chrono::steady_clock::now();
        early = vim::optimize<3>(image, grid, early_options);
        early_seconds = std::min(early_seconds, seconds_since(t0));
        if (rep == 0 &&
            vim::metrics::table1_metrics<3>(image, early.mesh, centre, 1.0).tf_percent > p->second)
          break;
        if (rep + 1 == repeat) early_iterations = k;
      }
    }
    if (early_iterations > 0)
      std::printf(
          "VIM-early done: %d iterations reach the paper's TF %.2f%% in %.2f s (fastest of %d; not "
          "converged)\n",
          early_iterations, p->second, early_seconds, repeat);
    std::fflush(stdout);
  }

  // CGAL: labeled image domain, tune s on refinement-only runs (node count ~ s^-3).
  const CGAL::Image_3 cimage = labeled_image(image, [](float v) { return v > 1.5f ? 2 : 1; });
  // A fresh domain per make_mesh_3 call: the domain owns the random generator (seeded 0) used for
  // the initial surface points, so reusing one domain makes every call different.
  auto domain_of = [&cimage] { return Mesh_domain::create_labeled_image_mesh_domain(cimage); };
  // The final runs repeat the tuned s (fresh domain = same seed = same refinement).
  const double s =
      tune_size(domain_of, target, std::cbrt(27.0 / static_cast<double>(target)) * 1.5, max_tuning);

  struct Row {
    const char* name;
    CgalMesh mesh;
    double seconds;
  };
  std::vector<Row> rows;
  // The fastest of `repeat` runs (a fresh domain each); the first run's mesh is scored.
  auto timed_rows = [&](const char* name, auto&& mesh_3) {
    double fastest = std::numeric_limits<double>::infinity(), slowest = 0.0;
    CgalMesh first;
    for (int k = 0; k < repeat; ++k) {
      const Mesh_domain domain = domain_of();
      t0 = std::chrono::steady_clock::now();
      const C3t3 c3t3 = mesh_3(domain);
      const double sec = seconds_since(t0);
      fastest = std::min(fastest, sec);
      slowest = std::max(slowest, sec);
      if (k == 0) first = extract(c3t3);
    }
    std::printf("  %s: fastest of %d %.3f s, slowest %.3f s\n", name, repeat, fastest, slowest);
    rows.push_back({name, std::move(first), fastest});
    return fastest;
  };
  const double pe_seconds = timed_rows("CGAL-pe", [&](const Mesh_domain& domain) {
    return CGAL::make_mesh_3<C3t3>(domain, criteria_for(s));  // perturb + exude (defaults)
  });
  timed_rows("CGAL-ol", [&](const Mesh_domain& domain) {
    return CGAL::make_mesh_3<C3t3>(domain, criteria_for(s), params::odt(params::time_limit = 60),
                                   params::lloyd(params::time_limit = 60));
  });

  if (match_tf) {
    // Equal accuracy: the largest s whose refinement reaches VIM's TF% (TF falls as s shrinks, up to
    // the noise of CGAL's random initial points), by geometric bisection from the equal-node s.
    std::printf("\nEqual-accuracy tuning: CGAL TF%% <= VIM's %.2f%% (refinement only, VIM object rule)\n",
                vm.tf_percent);
    double meets = 0.0, fails = s, t = s / 1.6;
    for (int run = 0; run < 2 * max_tuning; ++run) {
      const Mesh_domain domain = domain_of();
      t0 = std::chrono::steady_clock::now();
      const C3t3 c3t3 =
          CGAL::make_mesh_3<C3t3>(domain, criteria_for(t), params::no_perturb(), params::no_exude());
      const double sec = seconds_since(t0);
      const CgalMesh m = extract(c3t3);
      const auto tm = vim::metrics::table1_metrics<3>(image, m.mesh, centre, 1.0);
      std::printf("  tuning %d: s=%.5f -> %zu nodes, TF %.2f%% (%.2f s)\n", run, t, m.mesh.n_points(),
                  tm.tf_percent, sec);
      std::fflush(stdout);
      if (tm.tf_percent <= vm.tf_percent)
        meets = std::max(meets, t);
      else
        fails = std::min(fails, t);
      if (meets > 0.0 && fails / meets < 1.03) break;
      t = meets > 0.0 ? std::sqrt(meets * fails) : t / 1.6;
    }
    if (meets > 0.0) {
      const Mesh_domain domain = domain_of();
      t0 = std::chrono::steady_clock::now();
      const C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria_for(meets));
      const double sec = seconds_since(t0);
      rows.push_back({"CGAL-pe@TF", extract(c3t3), sec});
      std::printf("  CGAL-pe@TF: s=%.5f\n", meets);
    } else {
      std::printf("  no tuning run reached VIM's TF%%: CGAL-pe@TF not run\n");
    }
  }

  std::printf("\nCGAL s=%.5f (facet_size=cell_size=s, facet_distance=s/4, facet_angle=25, radius_edge=3)\n",
              s);
  std::printf("CGAL-pe = refine+perturb+exude; CGAL-ol = refine+ODT+Lloyd(+perturb+exude)\n");
  print_header();
  print_row("VIM", r.mesh, vm, vim_seconds, vim_seconds);
  print_row("VIM-full", full.mesh, vim::metrics::table1_metrics<3>(image, full.mesh, centre, 1.0),
            full_seconds, vim_seconds);
  if (early_iterations > 0)
    print_row("VIM-early", early.mesh, vim::metrics::table1_metrics<3>(image, early.mesh, centre, 1.0),
              early_seconds, vim_seconds);
  for (const Row& row : rows) {
    const auto m = vim::metrics::table1_metrics<3>(image, row.mesh.mesh, centre, 1.0);
    print_row(row.name, row.mesh.mesh, m, row.seconds, vim_seconds);
  }
  if (early_iterations > 0)
    std::printf(
        "VIM-early (%d iterations, stopped before Eq. 9 convergence, TF at most the paper's): %.2f x "
        "CGAL-pe\n",
        early_iterations, early_seconds / pe_seconds);
  std::printf(
      "VIM's set-up + swap passes alone: %.3f s = %.2f x CGAL-pe (the node updates are the other %.3f s)\n",
      setup_seconds + swap_seconds, (setup_seconds + swap_seconds) / pe_seconds, node_seconds);
  std::printf("\nCGAL with the subdomain rule (object = tets CGAL labelled 2):\n");
  for (const Row& row : rows) {
    std::vector<bool> object(row.mesh.subdomain.size());
    for (std::size_t c = 0; c < object.size(); ++c) object[c] = row.mesh.subdomain[c] == 2;
    const auto m = vim::metrics::sphere_metrics<3>(image, row.mesh.mesh, object, centre, 1.0);
    std::printf("%-10s FN %7ld FP %7ld TF %7ld TF%% %6.2f%%  (node ratio CGAL/VIM %.3f)\n", row.name, m.fn,
                m.fp, m.tf, m.tf_percent,
                static_cast<double>(row.mesh.mesh.n_points()) / static_cast<double>(target));
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_cgal_mesh3: %s\n", e.what());
  return 1;
}

// VIM on labels vs CGAL Mesh_3's Labeled_mesh_domain_3 on the same multi-label image at (about) the
// same node count, in one run (docs/cgal_comparison.md, "Labels"). The label image is an uncompressed
// NIfTI-1 file (e.g. `vim-make-phantom prostate p.mha --labels labels.nii`) or an INRIMAGE, read,
// strided and renumbered 1..k by label_image_io.hpp.
// VIM: vim::optimize_labels, default VimOptions, from the regular Kuhn grid at the node budget; each
// element labelled by the majority rule. CGAL: make_mesh_3 with its default optimisers (perturb +
// exude), s (facet_size = cell_size = s, facet_distance = s/4) tuned on refinement-only runs to VIM's
// node count (cgal_mesh3.hpp); each element labelled by its subdomain. The same independent code
// (bench/cgal/label_metrics.hpp) scores both meshes: per label, the voxel centres in an element of another
// label as a fraction of the label's voxels (volume fractions: all voxels have the same volume), and
// the centres in no element (CGAL's boundary facets approximate the box, so it leaves some out). Row
// "CGAL-maj" scores CGAL's mesh with the majority rule instead of its subdomains. Times are the fastest of
// --repeat runs (meshing only; scoring excluded).
//
//   bench_cgal_labels LABELS [--stride 1] [--nodes 1000] [--threads 0] [--repeat 3] [--max-tuning 8]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/vim.hpp>

#include "cgal_mesh3.hpp"
#include "label_image_io.hpp"
#include "label_metrics.hpp"

namespace {

using namespace vim::cgal_bench;

struct Scored {
  std::string name;
  vim::SimplexMesh<3> mesh;
  vim::metrics::LabelScore score;
  double seconds;
};

Scored scored(std::string name, const vim::Image<3>& image, const vim::SimplexMesh<3>& mesh,
              const std::vector<int>& cell_label, double seconds) {
  const auto owner = vim::metrics::voxel_owners<3>(image, mesh);
  return {std::move(name), mesh, vim::metrics::label_score<3>(image, owner, cell_label), seconds};
}

void print_tables(const std::vector<Scored>& rows, double vim_seconds) {
  std::printf("\n%-9s %6s %8s %8s %8s %9s %9s %10s %9s %10s\n", "method", "nodes", "elements", "minDA",
              "maxDA", "seconds", "VIM/this", "miscl.%", "uncovered", "miscl+unc%");
  for (const Scored& r : rows) {
    const auto q = vim::metrics::quality<3>(r.mesh);
    long voxels = 0, uncovered = 0;
    for (const auto& [l, n] : r.score.voxels) voxels += n, uncovered += r.score.uncovered.at(l);
    std::printf(
        "%-9s %6zu %8zu %8.3f %8.3f %9.3f %9.3f %9.3f%% %9ld %9.3f%%\n", r.name.c_str(), r.mesh.n_points(),
        r.mesh.n_cells(), q.min_angle, q.max_angle, r.seconds, vim_seconds / r.seconds,
        100.0 * static_cast<double>(r.score.total_misclassified()) / static_cast<double>(voxels), uncovered,
        100.0 * static_cast<double>(r.score.total_misclassified() + uncovered) / static_cast<double>(voxels));
  }
  std::printf("\nper label: misclassified voxels / the label's voxels (%%), [uncovered]\n%-6s %9s", "label",
              "voxels");
  for (const Scored& r : rows) std::printf(" %18s", r.name.c_str());
  std::printf("\n");
  for (const auto& [l, n] : rows.front().score.voxels) {
    std::printf("%-6d %9ld", l, n);
    for (const Scored& r : rows)
      std::printf(" %9.3f%% [%5ld]",
                  100.0 * static_cast<double>(r.score.misclassified.at(l)) / static_cast<double>(n),
                  r.score.uncovered.at(l));
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) try {
  long budget = 1000, stride = 1;
  int max_tuning = 8, repeat = 3;
  std::string path;
  vim::VimOptions options;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--nodes"))
      budget = std::atol(value("--nodes"));
    else if (!std::strcmp(argv[i], "--stride"))
      stride = std::max(1L, std::atol(value("--stride")));
    else if (!std::strcmp(argv[i], "--threads"))
      options.threads = std::atoi(value("--threads"));
    else if (!std::strcmp(argv[i], "--max-tuning"))
      max_tuning = std::atoi(value("--max-tuning"));
    else if (!std::strcmp(argv[i], "--repeat"))
      repeat = std::max(1, std::atoi(value("--repeat")));
    else if (argv[i][0] != '-' && path.empty())
      path = argv[i];
    else
      throw std::invalid_argument(std::string("unknown argument ") + argv[i]);
  }
  if (path.empty())
    throw std::invalid_argument("usage: bench_cgal_labels LABELS [--stride S] [--nodes N] ...");
  options.validate();
  const vim::Image<3> image = label_image(path, stride);
  const Eigen::Vector3d lo = image.box_min(), hi = image.box_max();
  std::printf(
      "VIM labels vs CGAL %d.%d Labeled_mesh_domain_3: %s, %ld x %ld x %ld voxels; target %ld nodes\n",
      CGAL_VERSION_MAJOR, CGAL_VERSION_MINOR, path.c_str(), image.size[0], image.size[1], image.size[2],
      budget);
  std::fflush(stdout);

  const vim::SimplexMesh<3> grid =
      vim::regular_grid_mesh<3>(lo, hi, vim::nodes_per_axis_for_budget<3>(lo, hi, budget));
  double vim_seconds = std::numeric_limits<double>::infinity();
  vim::VimResult<3> r;
  for (int k = 0; k < repeat; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    vim::VimResult<3> run = vim::optimize_labels<3>(image, grid, options);
    vim_seconds = std::min(vim_seconds, seconds_since(t0));
    if (k > 0 && (run.mesh.cells != r.mesh.cells || run.mesh.points != r.mesh.points))
      throw std::runtime_error("VIM gave a different mesh on repeat " + std::to_string(k));
    r = std::move(run);
  }
  std::printf("VIM done: %zu nodes, %zu elements, %.2f s (fastest of %d), %zu iterations (threads %d)\n",
              r.mesh.n_points(), r.mesh.n_cells(), vim_seconds, repeat, r.history.size() - 1,
              options.threads);
  std::fflush(stdout);

  const CGAL::Image_3 cimage = labeled_image(image, [](float v) { return static_cast<int>(std::lround(v)); });
  auto domain_of = [&cimage] { return Mesh_domain::create_labeled_image_mesh_domain(cimage); };
  const double volume = (hi - lo).prod();
  const long target = static_cast<long>(r.mesh.n_points());
  const double s =
      tune_size(domain_of, target, std::cbrt(volume / static_cast<double>(target)) * 1.5, max_tuning);
  double cgal_seconds = std::numeric_limits<double>::infinity();
  CgalMesh cgal;
  for (int k = 0; k < repeat; ++k) {
    const Mesh_domain domain = domain_of();
    const auto t0 = std::chrono::steady_clock::now();
    const C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria_for(s));  // perturb + exude (defaults)
    cgal_seconds = std::min(cgal_seconds, seconds_since(t0));
    if (k == 0) cgal = extract(c3t3);  // the first run's mesh is scored
  }
  std::printf("CGAL done: s=%.4f, %zu nodes, %.2f s (fastest of %d, refinement + perturb + exude)\n", s,
              cgal.mesh.n_points(), cgal_seconds, repeat);

  std::vector<Scored> rows;
  rows.push_back(scored("VIM", image, r.mesh, r.labels, vim_seconds));
  rows.push_back(scored("CGAL", image, cgal.mesh, cgal.subdomain, cgal_seconds));
  const auto cgal_majority =
      vim::metrics::majority_labels<3>(image, cgal.mesh, vim::metrics::voxel_owners<3>(image, cgal.mesh));
  rows.push_back(scored("CGAL-maj", image, cgal.mesh, cgal_majority, cgal_seconds));
  const auto vim_majority =
      vim::metrics::majority_labels<3>(image, r.mesh, vim::metrics::voxel_owners<3>(image, r.mesh));
  long differ = 0;
  for (std::size_t c = 0; c < vim_majority.size(); ++c) differ += vim_majority[c] != r.labels[c] ? 1 : 0;
  std::printf("VIM's element labels vs the independent majority rule: %ld of %zu differ\n", differ,
              r.labels.size());
  print_tables(rows, vim_seconds);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_cgal_labels: %s\n", e.what());
  return 1;
}

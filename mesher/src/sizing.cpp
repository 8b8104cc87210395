// Mesh sizing of paper §VI-E: density-weighted E_G-only optimisation (ρ at the element centroid)
// used to initialise VIM with a non-uniform mesh.
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/optimizer.hpp>
#include <vim/sizing.hpp>

namespace vim {

template <int dim>
void validate_density(const Image<dim>& density) {
  if (density.data.empty() || density.data.size() != density.voxel_count())
    throw std::invalid_argument("sizing image is empty or its data does not match its size");
  for (float v : density.data)
    if (!(std::isfinite(v) && v > 0.0f)) {
      std::ostringstream m;
      m << "sizing image has value " << v << ": densities must be finite and > 0";
      throw std::invalid_argument(m.str());
    }
}

template <int dim>
SimplexMesh<dim> size_initial_mesh(const Image<dim>& density, SimplexMesh<dim> mesh, int iterations,
                                   const VimOptions& options, const ProgressCallback& progress) {
  if (iterations < 0) throw std::invalid_argument("sizing iterations must be >= 0");
  validate_density(density);
  VimOptions geometric = options;
  geometric.lambda = 0.0;
  geometric.insert_nodes = 0;
  VimOptimizer<dim> opt(std::move(mesh), nullptr, &density, geometric);
  const double b = opt.bbox_diagonal();
  double e_before = opt.totals().energy;
  for (int it = 1; it <= iterations; ++it) {
    const auto t0 = std::chrono::steady_clock::now();
    IterationRecord r;
    r.iteration = it;
    double sum_sq = 0.0;
    r.moves = opt.update_nodes(it, &sum_sq, &r.searched, &r.evaluations);
    r.v = std::sqrt(sum_sq / static_cast<double>(opt.mesh().n_points())) / b;
    if (geometric.swaps) {
      r.swaps = opt.swap_pass();
      if (r.swaps > 0) opt.recolour();
    }
    // The convergence rule of optimize(): Eq. 9 and E settled (a density that is flat over most of
    // the domain leaves most nodes still, which dilutes Eq. 9's RMS).
    const EnergyTotals t = opt.totals();
    r.energy = t.energy;
    r.geometric = t.geometric;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(r);
    if (geometric.converged(r.v, e_before, r.energy)) break;
    e_before = r.energy;
  }
  return opt.compact_mesh();
}

template <int dim>
VimResult<dim> optimize_sized(const Image<dim>& image, const Image<dim>& density, SimplexMesh<dim> initial,
                              const VimOptions& options, const ProgressCallback& progress) {
  SimplexMesh<dim> sized =
      size_initial_mesh<dim>(density, std::move(initial), options.max_iterations, options);
  return optimize<dim>(image, std::move(sized), options, progress, &density);
}

template VimResult<2> optimize_sized<2>(const Image<2>&, const Image<2>&, SimplexMesh<2>, const VimOptions&,
                                        const ProgressCallback&);
template VimResult<3> optimize_sized<3>(const Image<3>&, const Image<3>&, SimplexMesh<3>, const VimOptions&,
                                        const ProgressCallback&);
template void validate_density<2>(const Image<2>&);
template void validate_density<3>(const Image<3>&);
template SimplexMesh<2> size_initial_mesh<2>(const Image<2>&, SimplexMesh<2>, int, const VimOptions&,
                                             const ProgressCallback&);
template SimplexMesh<3> size_initial_mesh<3>(const Image<3>&, SimplexMesh<3>, int, const VimOptions&,
                                             const ProgressCallback&);

}  // namespace vim

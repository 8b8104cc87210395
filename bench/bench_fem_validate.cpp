// The full deformation-validation sweep of docs/validation.md (the CI runs a small subset in
// tests/validation): for each scenario and node budget, the VIM model and the regular-grid model
// with the same node count are solved and compared with the fine voxel reference under identical
// uniaxial compression. Prints relative L2 / max displacement error, strain-energy error and the
// VIM/grid error ratio.
//
//   bench_fem_validate [--scenario sphere|inclusions|all|random] [--seed 1] [--n3 40] [--n2 128] [nodes ...]
// (random: 3–6 spheres of random centre, radius and modulus from --seed; not part of "all")
#include "deformation.hpp"
#include "metrics.hpp"

#include <vim/initial_mesh.hpp>
#include <vim/vim.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deal.II/base/mpi.h>
#include <exception>
#include <string>
#include <vector>

namespace {

constexpr double kNu = 0.3, kStrain = 0.05;

template <int dim>
void sweep(const char* name, const vim::Image<dim>& image, const std::vector<long>& budgets, long stride) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto ref = vim::validation::solve_reference<dim>(image, kNu, kStrain, stride);
  std::printf("\n## %s: %ld^%d voxels, reference %u DoFs (%.1f s), %zu sample points, nu=%.2f, strain=%.2f\n",
              name, image.size[0], dim, ref.n_dofs,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), ref.points.size(), kNu,
              kStrain);
  std::printf("| nodes | cells grid | cells VIM | relL2 grid | relL2 VIM | VIM/grid | max/|u|max grid | max/|u|max VIM | "
              "energy err grid | energy err VIM | VIM s |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (long budget : budgets) {
    const auto axis = vim::nodes_per_axis_for_budget<dim>(image.box_min(), image.box_max(), budget);
    const auto grid = vim::regular_grid_mesh<dim>(image.box_min(), image.box_max(), axis);
    const auto g = vim::validation::coarse_error<dim>(image, grid, vim::validation::element_moduli<dim>(image, grid),
                                                      kNu, kStrain, ref);
    const auto t1 = std::chrono::steady_clock::now();
    const auto r = vim::optimize<dim>(image, grid, vim::VimOptions{});
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    std::vector<double> moduli;
    for (const auto& v : r.values) moduli.push_back(v.mean);  // Eq. 15
    const auto v = vim::validation::coarse_error<dim>(image, r.mesh, moduli, kNu, kStrain, ref);
    std::printf("| %zu | %zu | %zu | %.4f | %.4f | %.3f | %.4f | %.4f | %.4f | %.4f | %.1f |\n", grid.n_points(),
                grid.n_cells(), r.mesh.n_cells(), g.relative_l2, v.relative_l2, v.relative_l2 / g.relative_l2,
                g.max / g.max_reference, v.max / v.max_reference, g.energy_relative, v.energy_relative, seconds);
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) try {
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  std::string scenario = "all";
  long n3 = 40, n2 = 128, seed = 1;
  std::vector<long> budgets;
  for (int i = 1; i < argc; ++i) {
    auto value = [&] {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(argv[i]) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--scenario")) scenario = value();
    else if (!std::strcmp(argv[i], "--n3")) n3 = std::atol(value());
    else if (!std::strcmp(argv[i], "--n2")) n2 = std::atol(value());
    else if (!std::strcmp(argv[i], "--seed")) seed = std::atol(value());
    else budgets.push_back(std::atol(argv[i]));
  }
  if (budgets.empty()) budgets = {125, 343, 1000, 4096};
  if (scenario == "sphere" || scenario == "all")
    sweep<3>("sphere compression (Table I geometry, sphere 10x stiffer)",
             vim::metrics::inclusion_phantom<3>(n3, 3.0, {{{1.5, 1.5, 1.5}, 1.0, 10.0f}}, 1.0f), budgets, 2);
  if (scenario == "random") {
    // A synthetic elastogram not tuned to anything (metrics::random_spheres).
    const auto spheres = vim::metrics::random_spheres(static_cast<unsigned>(seed));
    for (std::size_t i = 0; i < spheres.size(); ++i)
      std::printf("# sphere %zu: centre (%.2f, %.2f, %.2f), radius %.2f, modulus %.2f\n", i, spheres[i].centre[0],
                  spheres[i].centre[1], spheres[i].centre[2], spheres[i].radius, spheres[i].value);
    sweep<3>("random spheres compression (seeded)", vim::metrics::random_spheres_phantom(n3, static_cast<unsigned>(seed)),
             budgets, 2);
  }
  if (scenario == "inclusions" || scenario == "all")
    sweep<2>("2D two-inclusion compression (inclusions 10x stiffer)",
             vim::metrics::inclusion_phantom<2>(n2, 1.0, {{{0.32, 0.34, 0.0}, 0.16, 10.0f}, {{0.66, 0.65, 0.0}, 0.2, 10.0f}},
                                                1.0f),
             budgets, 1);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_fem_validate: %s\n", e.what());
  return 1;
}

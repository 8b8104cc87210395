// The meshing options of a run, with their defaults, in one place: the command line's (--nodes …
// --degree, cli.cpp), RunOptions' (which is a MeshOptions), the Python module's keywords (vimpipeline.mesh
// reads its defaults from here) and a scenario's mesh keys, which apply wherever the caller did not set
// the option (with_scenario_mesh, the one rule for all of them).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

// The mesher's own options (λ, quality bounds, iterations, convergence, threads, seed) take VimOptions'
// defaults; the initial grid and the FEM degree are the run's.
struct MeshOptions {
  long nodes = 1000;     // --nodes: node budget of the initial regular grid
  double spacing = 0.0;  // --spacing: initial grid edge length in image units (0 = use --nodes)
  double lambda = VimOptions{}.lambda;
  double max_dihedral_deg = VimOptions{}.max_dihedral_deg;
  double min_dihedral_deg = VimOptions{}.min_dihedral_deg;  // --min-dihedral: optional lower bound (0 = off)
  double min_radius_ratio =
      VimOptions{}.min_radius_ratio;  // --min-radius-ratio: d·r_in/R_circ floor (0 = off)
  int max_iterations = VimOptions{}.max_iterations;
  double convergence = VimOptions{}.convergence;                // --convergence: Eq. 9 threshold on v
  double energy_convergence = VimOptions{}.energy_convergence;  // and E falling less than this per iteration
  int search_width = VimOptions{}.search_width;  // --search-width: 0 = every direction searched in full
  int threads = VimOptions{}.threads;            // 0 = all cores (TBB default)
  std::uint64_t seed = VimOptions{}.seed;
  bool check_invariants = VimOptions{}.check_invariants;  // on by default in a VIM_CHECKED build
  int degree = 1;  // --degree: FEM polynomial degree (1 = P1, the paper's model; 2 = P2)

  // The mesher's options (threads, seed, λ, quality bounds, iterations) taken from these.
  VimOptions vim_options() const;
};

// `options` with the scenario's mesh keys (mesh.nodes, lambda, degree, min_dihedral) in place of the
// options the caller did not set: given(flag) tells whether the caller set the option of that
// command-line flag ("--nodes", "--spacing", "--lambda", "--degree", "--min-dihedral"); mesh.nodes
// yields to --nodes and to --spacing. Without `given`, every key the scenario has applies.
MeshOptions with_scenario_mesh(MeshOptions options, const Scenario& scenario,
                               const std::function<bool(const std::string& flag)>& given = nullptr);

}  // namespace vim::pipeline

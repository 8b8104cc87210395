// RunOptions (run_options.hpp): the mesher's options taken from the run's.
#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

std::string to_string(MesherKind m) {
  switch (m) {
    case MesherKind::vim:
      return "vim";
    case MesherKind::grid:
      return "grid";
    case MesherKind::voxel:
      return "voxel";
  }
  return "?";
}

VimOptions RunOptions::vim_options() const {
  VimOptions v;
  v.lambda = lambda;
  v.max_dihedral_deg = max_dihedral_deg;
  v.min_dihedral_deg = min_dihedral_deg;
  v.min_radius_ratio = min_radius_ratio;
  v.max_iterations = max_iterations;
  v.convergence = convergence;
  v.energy_convergence = energy_convergence;
  v.search_width = search_width;
  v.threads = threads;
  v.seed = seed;
  v.check_invariants = check_invariants;
  return v;
}

}  // namespace vim::pipeline

// RunOptions (run_options.hpp): the mesher table and the mesher's options taken from the run's.
#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

const std::vector<Mesher>& meshers() {
  static const std::vector<Mesher> table = {
      {MesherKind::vim, "vim", "VIM optimisation"},
      {MesherKind::grid, "grid", "the unoptimised initial grid with the same nodes"},
      {MesherKind::voxel, "voxel", "one cell per voxel (fine reference)"},
  };
  return table;
}

std::string to_string(MesherKind m) {
  for (const Mesher& row : meshers())
    if (row.kind == m) return row.name;
  return "?";
}

std::optional<MesherKind> mesher_kind(const std::string& name) {
  for (const Mesher& row : meshers())
    if (row.name == name) return row.kind;
  return std::nullopt;
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

// MeshOptions (mesh_options.hpp): the mesher's options taken from them and the scenario's mesh keys.
#include <vim/pipeline/scenario/mesh_options.hpp>

namespace vim::pipeline {

VimOptions MeshOptions::vim_options() const {
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

MeshOptions with_scenario_mesh(MeshOptions o, const Scenario& sc,
                               const std::function<bool(const std::string& flag)>& given) {
  auto set = [&](const char* flag) { return given && given(flag); };
  if (sc.nodes && !set("--nodes") && !set("--spacing")) o.nodes = *sc.nodes;
  if (sc.lambda && !set("--lambda")) o.lambda = *sc.lambda;
  if (sc.degree && !set("--degree")) o.degree = static_cast<int>(*sc.degree);
  if (sc.min_dihedral && !set("--min-dihedral")) o.min_dihedral_deg = *sc.min_dihedral;
  return o;
}

}  // namespace vim::pipeline

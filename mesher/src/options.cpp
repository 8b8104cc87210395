// VimOptions::validate — one place that checks every option and names it in the message.
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/vim.hpp>

namespace vim {

namespace {
[[noreturn]] void bad(const std::string& name, double value, const std::string& valid) {
  std::ostringstream s;
  s << "invalid option " << name << " = " << value << ": must be " << valid;
  throw std::invalid_argument(s.str());
}
}  // namespace

void VimOptions::validate() const {
  if (!(lambda >= 0.0 && lambda < 1.0)) bad("lambda", lambda, "in [0, 1)");
  if (!(max_dihedral_deg > 90.0 && max_dihedral_deg < 180.0))
    bad("max-dihedral", max_dihedral_deg, "in (90, 180) degrees");
  if (!(min_dihedral_deg >= 0.0 && min_dihedral_deg < 60.0))
    bad("min-dihedral", min_dihedral_deg, "in [0, 60) degrees");
  if (!(min_radius_ratio >= 0.0 && min_radius_ratio < 1.0))
    bad("min-radius-ratio", min_radius_ratio, "in [0, 1)");
  if (max_iterations < 0) bad("max-iterations", max_iterations, ">= 0");
  if (!(convergence > 0.0)) bad("convergence", convergence, "> 0");
  if (!(energy_convergence >= 0.0 && energy_convergence < 1.0))
    bad("energy-convergence", energy_convergence, "in [0, 1) (0 = Eq. 9 alone)");
  if (!(line_search_step > 0.0 && line_search_step <= 10.0))
    bad("line-search-step", line_search_step, "in (0, 10] voxels");
  if (search_width < 0) bad("search-width", search_width, ">= 0 (0 = search every direction)");
  if (random_walk_samples < 1) bad("random-walk-samples", random_walk_samples, ">= 1");
  if (threads < 0) bad("threads", threads, ">= 0 (0 = all cores)");
  if (insert_nodes < 0) bad("insert-nodes", insert_nodes, ">= 0");
  if (node_budget < 0) bad("node-budget", static_cast<double>(node_budget), ">= 0");
}

bool VimOptions::converged(double v, double e_before, double e_after) const {
  const bool settled = energy_convergence == 0.0 || !(e_before - e_after > energy_convergence * e_before);
  return v < convergence && settled;
}

}  // namespace vim

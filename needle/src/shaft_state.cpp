// The shaft state's compact views (vim/needle/shaft_state.hpp).
#include <vim/needle/shaft_state.hpp>

namespace vim::needle {

Eigen::VectorXd ShaftState::compact(const std::vector<double>& v) const {
  Eigen::VectorXd c(static_cast<Eigen::Index>(active.size()));
  for (std::size_t i = 0; i < active.size(); ++i) c[static_cast<Eigen::Index>(i)] = v[active[i]];
  return c;
}

void ShaftState::expand(const Eigen::VectorXd& c, std::vector<double>& v) const {
  for (std::size_t i = 0; i < active.size(); ++i) v[active[i]] = c[static_cast<Eigen::Index>(i)];
}

}  // namespace vim::needle

// The kinematic laws' friction limits per shaft point (friction_laws.hpp), and the stick-slip limit
// integrated along the path (PathProfile, friction_law.hpp).
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <utility>

#include "friction_laws.hpp"

namespace vim::needle {

PathProfile::PathProfile(std::vector<double> breaks, std::vector<double> values)
    : breaks_(std::move(breaks)), values_(std::move(values)) {
  if (values_.empty() || breaks_.size() != values_.size() + 1)
    throw std::invalid_argument("PathProfile: needs one more break than values, and at least one value");
  cumulative_.assign(breaks_.size(), 0.0);
  for (std::size_t i = 0; i < values_.size(); ++i) {
    if (!(breaks_[i + 1] > breaks_[i])) throw std::invalid_argument("PathProfile: breaks must increase");
    cumulative_[i + 1] = cumulative_[i] + values_[i] * (breaks_[i + 1] - breaks_[i]);
  }
}

std::size_t PathProfile::piece(double s) const {
  const auto it = std::upper_bound(breaks_.begin() + 1, breaks_.end() - 1, s);
  return static_cast<std::size_t>(it - (breaks_.begin() + 1));
}

// Within one piece q·(b − a) (a uniform q gives the point-sampled limit to rounding); across pieces
// the two partial pieces plus the whole ones between, without cancellation of large sums.
double PathProfile::integral(double a, double b) const {
  const std::size_t i = piece(a), k = piece(b);
  if (i == k) return values_[i] * (b - a);
  return values_[i] * (breaks_[i + 1] - a) + (cumulative_[k] - cumulative_[i + 1]) +
         values_[k] * (b - breaks_[k]);
}

double PathProfile::next_change(double s) const {
  const std::size_t i = piece(s);
  for (std::size_t k = i + 1; k < values_.size(); ++k)
    if (values_[k] != values_[i]) return breaks_[k];
  return std::numeric_limits<double>::infinity();
}

void friction_limits(const ShaftState& state, const FrictionOptions& options, bool stick,
                     std::vector<double>& limit) {
  const bool along_path = !options.shear_profile.empty();
  const std::size_t n_shaft = state.start.size();
  for (std::size_t j : state.active) {
    if (j == state.cutting)
      limit[j] = j >= n_shaft && !options.cutting_profile.empty() ? options.cutting_profile.at(state.front)
                                                                  : options.cutting_force_at(j);
    else if (stick)
      limit[j] = std::numeric_limits<double>::infinity();
    else if (along_path && j < state.start.size())
      limit[j] = options.shear_profile.integral(state.start[j], state.start[j] + state.carried[j]);
    else
      limit[j] = options.max_shear_per_length_at(j) * state.carried[j];
  }
}

}  // namespace vim::needle

// The kinematic laws' friction limits per shaft point (friction_laws.hpp).
#include <limits>

#include "friction_laws.hpp"

namespace vim::needle {

void friction_limits(const ShaftState& state, const FrictionOptions& options, bool stick,
                     std::vector<double>& limit) {
  for (std::size_t j : state.active)
    limit[j] = j == state.cutting ? options.cutting_force_at(j)
               : stick            ? std::numeric_limits<double>::infinity()
                                  : options.max_shear_per_length_at(j) * state.carried[j];
}

}  // namespace vim::needle

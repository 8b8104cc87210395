// The kinematic laws' friction limits per shaft point (friction_laws.hpp).
#include <cmath>

#include "friction_laws.hpp"

namespace vim::needle {

void friction_limits(const ShaftState& state, double cutting_force, double shear_per_length,
                     std::vector<double>& limit) {
  for (std::size_t j : state.active)
    limit[j] = j == state.cutting             ? cutting_force
               : std::isinf(shear_per_length) ? shear_per_length
                                              : shear_per_length * state.carried[j];
}

}  // namespace vim::needle

// Private to the needle library: the factories of the friction laws (vim/needle/friction_law.hpp), each
// law in its own file; friction_law.cpp lists them in the registry.
#pragma once

#include <memory>
#include <vector>
#include <vim/needle/friction_law.hpp>

namespace vim::needle {

// Kinematic needle, stick: every shaft point moves with the needle (friction_stick.cpp).
std::unique_ptr<FrictionLaw> make_stick_law(const FrictionOptions& options);
// Kinematic needle, stick-slip with a Coulomb limit per shaft length (friction_stick_slip.cpp).
std::unique_ptr<FrictionLaw> make_stick_slip_law(const FrictionOptions& options);
// Force needle: prescribed friction per shaft length and tip force (friction_force.cpp).
std::unique_ptr<FrictionLaw> make_force_law(const FrictionOptions& options);

// The kinematic laws' limit per active point: the cutting force for the tissue the tip pushes
// (state.cutting), else shear_per_length × the shaft length the point carries (+∞: the point sticks).
// (friction_limits.cpp)
void friction_limits(const ShaftState& state, double cutting_force, double shear_per_length,
                     std::vector<double>& limit);

}  // namespace vim::needle

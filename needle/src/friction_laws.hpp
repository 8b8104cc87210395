// Private to the needle library: the factories of the friction laws (vim/needle/friction_law.hpp), each
// law in its own file; friction_law.cpp lists them in the registry.
#pragma once

#include <memory>
#include <vim/needle/friction_law.hpp>

namespace vim::needle {

// Kinematic needle, stick: every shaft point moves with the needle (friction_stick.cpp).
std::unique_ptr<FrictionLaw> make_stick_law(const FrictionOptions& options);
// Kinematic needle, stick-slip with a Coulomb limit per shaft length (friction_stick_slip.cpp).
std::unique_ptr<FrictionLaw> make_stick_slip_law(const FrictionOptions& options);
// Force needle: prescribed friction per shaft length and tip force (friction_force.cpp).
std::unique_ptr<FrictionLaw> make_force_law(const FrictionOptions& options);

}  // namespace vim::needle

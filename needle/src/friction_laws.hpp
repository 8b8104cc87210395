// Private to the needle library: the factories of the friction laws (vim/needle/friction_law.hpp), the
// kinematic ones in one file, the force law in another; friction_law.cpp lists them in the registry.
#pragma once

#include <memory>
#include <vector>
#include <vim/needle/friction_law.hpp>

namespace vim::needle {

// Kinematic needle, stick: every shaft point moves with the needle (friction_kinematic.cpp).
std::unique_ptr<FrictionLaw> make_stick_law(const FrictionOptions& options);
// Kinematic needle, stick-slip with a Coulomb limit per shaft length (friction_kinematic.cpp).
std::unique_ptr<FrictionLaw> make_stick_slip_law(const FrictionOptions& options);
// Force needle: prescribed friction per shaft length and tip force (friction_force.cpp).
std::unique_ptr<FrictionLaw> make_force_law(const FrictionOptions& options);

// The kinematic laws' limit per active point (friction_limits.cpp): the cutting force of the tissue
// at the point the tip pushes (state.cutting), else +∞ for the stick law (`stick`) or the point's
// limit per length × the shaft length it carries. Per-point values (the tissue at each point) come
// from FrictionOptions::cutting_force_at / max_shear_per_length_at.
void friction_limits(const ShaftState& state, const FrictionOptions& options, bool stick,
                     std::vector<double>& limit);

}  // namespace vim::needle

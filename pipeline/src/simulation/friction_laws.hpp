// Private to friction_law.cpp: the friction laws of the needle (needle_coupling.hpp), each in its
// own file. A new law adds a file and a line in make_friction_law.
#pragma once

#include <memory>
#include <vector>
#include <vim/pipeline/simulation/needle_coupling.hpp>

namespace vim::pipeline {

// The kinematic laws' active set (friction_law.cpp): every active point sticks unless its axial load
// exceeds limit[j] (per point; +∞: always sticks), then it slides at ±limit. `sliding` and `sign` (per
// point) are kept between steps by the law. Leaves the tissue solved with the final values.
FrictionStep settle_active_set(ShaftState& state, TissueResponse& tissue, const std::vector<double>& limit,
                               std::vector<bool>& sliding, std::vector<double>& sign, int max_sweeps);

// Kinematic needle, stick: every shaft point moves with the needle (friction_stick.cpp).
std::unique_ptr<FrictionLaw> make_stick_law(const NeedleSpec& spec, int max_sweeps);
// Kinematic needle, stick-slip with a Coulomb limit per shaft length (friction_stick_slip.cpp).
std::unique_ptr<FrictionLaw> make_stick_slip_law(const NeedleSpec& spec, int max_sweeps);
// Force needle: prescribed friction per shaft length and tip force (friction_force.cpp).
std::unique_ptr<FrictionLaw> make_force_law(const NeedleSpec& spec);

}  // namespace vim::pipeline

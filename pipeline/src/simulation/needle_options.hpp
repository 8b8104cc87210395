// Private to the simulation sources: the one translation of a scenario's needle (NeedleSpec, world
// coordinates) into the needle library's options (frame coordinates).
#pragma once

#include <vim/needle/needle_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// The friction law of needle.model / needle.friction and its parameters; max_active_set_iterations
// caps the stick-slip sweeps per step.
needle::FrictionOptions friction_options(const NeedleSpec& spec, int max_active_set_iterations);

// The needle's path in the frame, its stepping, geometry and law.
template <int dim>
needle::NeedleOptions<dim> needle_options(const NeedleSpec& spec, const WorldTransform<dim>& transform,
                                          int max_active_set_iterations);

}  // namespace vim::pipeline

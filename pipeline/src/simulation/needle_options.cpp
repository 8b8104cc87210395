// A scenario's needle as the needle library's options (needle_options.hpp).
#include "simulation/needle_options.hpp"

namespace vim::pipeline {

needle::FrictionOptions friction_options(const NeedleSpec& spec, int max_active_set_iterations) {
  needle::FrictionOptions o;
  o.law = spec.model == NeedleSpec::Model::force              ? "force"
          : spec.friction == NeedleSpec::Friction::stick_slip ? "stick-slip"
                                                              : "stick";
  o.max_shear_per_length = spec.max_shear_per_length;
  o.friction_per_length = spec.friction_per_length;
  o.tip_force = spec.tip_force;
  o.cutting_distance = spec.cutting_distance;
  o.cutting_force = spec.cutting_force;
  o.max_sweeps = max_active_set_iterations;
  return o;
}

template <int dim>
needle::NeedleOptions<dim> needle_options(const NeedleSpec& spec, const WorldTransform<dim>& transform,
                                          int max_active_set_iterations) {
  needle::NeedleOptions<dim> o;
  o.path = needle_path<dim>(spec, transform);
  o.steps = spec.steps;
  o.diameter = spec.diameter;
  o.sample_spacing = spec.sample_spacing;
  o.coupling_radius = spec.coupling_radius;
  o.friction = friction_options(spec, max_active_set_iterations);
  return o;
}

template needle::NeedleOptions<2> needle_options<2>(const NeedleSpec&, const WorldTransform<2>&, int);
template needle::NeedleOptions<3> needle_options<3>(const NeedleSpec&, const WorldTransform<3>&, int);

}  // namespace vim::pipeline

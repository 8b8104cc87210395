// Private to the simulation sources: the one translation of a scenario's needle (NeedleSpec, world
// coordinates) into the needle library's options (frame coordinates).
#pragma once

#include <functional>
#include <vim/fem/conditions.hpp>
#include <vim/needle/needle_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// The friction law of needle.model / needle.friction and its parameters; max_active_set_iterations
// caps the stick-slip sweeps per step.
needle::FrictionOptions friction_options(const NeedleSpec& spec, int max_active_set_iterations);

// The needle.tissues entry at a frame position: the first whose region holds it, or whose modulus
// range holds modulus_at(position); -1 where none does. region(r): the scenario region as a frame
// predicate.
template <int dim>
std::function<int(const Eigen::Matrix<double, dim, 1>&)> tissue_lookup(
    const NeedleSpec& spec, const std::function<fem::Region<dim>(const RegionSpec&)>& region,
    const std::function<double(const Eigen::Matrix<double, dim, 1>&)>& modulus_at);

// The needle.tissues entry of each shaft point (frame positions).
template <int dim>
std::vector<int> point_tissues(const std::function<int(const Eigen::Matrix<double, dim, 1>&)>& lookup,
                               const std::vector<Eigen::Matrix<double, dim, 1>>& points);

// The kinematic law's values along the path, from the tissue the path crosses (the needle's own where
// no entry holds it; docs/needle-model.md, the values along the path): stick-slip, the limit per
// length (FrictionOptions::shear_profile); 3D with a cutting force somewhere, the cutting force
// (cutting_profile). Piecewise constant, their changes found between samples `spacing` apart along
// [0, path.depth]. Call after set_point_values.
template <int dim>
void set_path_values(const NeedleSpec& spec,
                     const std::function<int(const Eigen::Matrix<double, dim, 1>&)>& lookup,
                     const needle::NeedlePath<dim>& path, double spacing, needle::FrictionOptions& friction);

// The friction law's per-point values (FrictionOptions::point_*) of the points' tissues.
void set_point_values(const NeedleSpec& spec, const std::vector<int>& tissue,
                      needle::FrictionOptions& friction);

// The needle's path in the frame, its stepping, geometry and law.
template <int dim>
needle::NeedleOptions<dim> needle_options(const NeedleSpec& spec, const WorldTransform<dim>& transform,
                                          int max_active_set_iterations);

}  // namespace vim::pipeline

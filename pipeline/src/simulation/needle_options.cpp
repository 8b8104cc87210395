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
std::vector<int> point_tissues(
    const NeedleSpec& spec, const std::vector<Eigen::Matrix<double, dim, 1>>& points,
    const std::function<fem::Region<dim>(const RegionSpec&)>& region,
    const std::function<double(const Eigen::Matrix<double, dim, 1>&)>& modulus_at) {
  std::vector<std::function<bool(const Eigen::Matrix<double, dim, 1>&)>> holds;
  for (const TissueSpec& t : spec.tissues) {
    if (t.region) {
      holds.push_back(region(*t.region).contains);
    } else {
      holds.push_back([&t, &modulus_at](const Eigen::Matrix<double, dim, 1>& x) {
        const double e = modulus_at(x);
        return e >= t.modulus_min && e <= t.modulus_max;
      });
    }
  }
  std::vector<int> tissue(points.size(), -1);
  for (std::size_t j = 0; j < points.size(); ++j)
    for (std::size_t i = 0; i < holds.size() && tissue[j] < 0; ++i)
      if (holds[i](points[j])) tissue[j] = static_cast<int>(i);
  return tissue;
}

void set_point_values(const NeedleSpec& spec, const std::vector<int>& tissue, needle::FrictionOptions& o) {
  o.point_max_shear_per_length.assign(tissue.size(), spec.max_shear_per_length);
  o.point_cutting_force.assign(tissue.size(), spec.cutting_force);
  for (std::size_t j = 0; j < tissue.size(); ++j) {
    if (tissue[j] < 0) continue;
    const TissueSpec& t = spec.tissues[static_cast<std::size_t>(tissue[j])];
    o.point_max_shear_per_length[j] = t.max_shear_per_length.value_or(spec.max_shear_per_length);
    o.point_cutting_force[j] = t.cutting_force.value_or(spec.cutting_force);
  }
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

template std::vector<int> point_tissues<2>(const NeedleSpec&, const std::vector<Eigen::Vector2d>&,
                                           const std::function<fem::Region<2>(const RegionSpec&)>&,
                                           const std::function<double(const Eigen::Vector2d&)>&);
template std::vector<int> point_tissues<3>(const NeedleSpec&, const std::vector<Eigen::Vector3d>&,
                                           const std::function<fem::Region<3>(const RegionSpec&)>&,
                                           const std::function<double(const Eigen::Vector3d&)>&);
template needle::NeedleOptions<2> needle_options<2>(const NeedleSpec&, const WorldTransform<2>&, int);
template needle::NeedleOptions<3> needle_options<3>(const NeedleSpec&, const WorldTransform<3>&, int);

}  // namespace vim::pipeline

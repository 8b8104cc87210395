// A scenario's needle as the needle library's options (needle_options.hpp).
#include "simulation/needle_options.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

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
std::function<int(const Eigen::Matrix<double, dim, 1>&)> tissue_lookup(
    const NeedleSpec& spec, const std::function<fem::Region<dim>(const RegionSpec&)>& region,
    const std::function<double(const Eigen::Matrix<double, dim, 1>&)>& modulus_at) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  std::vector<std::function<bool(const Vec&)>> holds;
  for (const TissueSpec& t : spec.tissues) {
    if (t.region) {
      holds.push_back(region(*t.region).contains);
    } else {
      const double lo = t.modulus_min, hi = t.modulus_max;
      holds.push_back([lo, hi, modulus_at](const Vec& x) {
        const double e = modulus_at(x);
        return e >= lo && e <= hi;
      });
    }
  }
  return [holds](const Vec& x) {
    for (std::size_t i = 0; i < holds.size(); ++i)
      if (holds[i](x)) return static_cast<int>(i);
    return -1;
  };
}

template <int dim>
std::vector<int> point_tissues(const std::function<int(const Eigen::Matrix<double, dim, 1>&)>& lookup,
                               const std::vector<Eigen::Matrix<double, dim, 1>>& points) {
  std::vector<int> tissue(points.size(), -1);
  for (std::size_t j = 0; j < points.size(); ++j) tissue[j] = lookup(points[j]);
  return tissue;
}

// Samples every `spacing` along [0, length]; where the value differs between two samples, the change
// is found by bisection to 1e-13 of the length (a piece shorter than the spacing between two samples of
// the same value is missed).
template <int dim>
needle::PathProfile path_profile(const std::function<int(const Eigen::Matrix<double, dim, 1>&)>& lookup,
                                 const std::function<double(int tissue)>& value_of,
                                 const needle::NeedlePath<dim>& path, double length, double spacing) {
  const auto v_at = [&](double s) { return value_of(lookup(path.entry + s * path.axis)); };
  const int n = std::max(1, static_cast<int>(std::ceil(length / spacing)));
  std::vector<double> breaks{0.0}, values{v_at(0.0)};
  double s0 = 0.0;
  for (int k = 1; k <= n; ++k) {
    const double s1 = length * k / n;
    const double v1 = v_at(s1);
    if (v1 != values.back()) {
      double lo = s0, hi = s1;  // v(lo) = values.back(), v(hi) differs
      while (hi - lo > 1e-13 * length) {
        const double mid = 0.5 * (lo + hi);
        (v_at(mid) == values.back() ? lo : hi) = mid;
      }
      breaks.push_back(hi);
      values.push_back(v_at(hi));
      if (values.back() != v1) {  // a third value between the samples: take it up to s1
        breaks.push_back(s1);
        values.push_back(v1);
      }
    }
    s0 = s1;
  }
  breaks.push_back(std::max(length, breaks.back() + spacing));
  return {std::move(breaks), std::move(values)};
}

template <int dim>
void set_path_values(const NeedleSpec& spec,
                     const std::function<int(const Eigen::Matrix<double, dim, 1>&)>& lookup,
                     const needle::NeedlePath<dim>& path, double spacing, needle::FrictionOptions& o) {
  const auto entry = [&spec](int tissue) -> const TissueSpec* {
    return tissue < 0 ? nullptr : &spec.tissues[static_cast<std::size_t>(tissue)];
  };
  const std::function<double(int)> shear = [&](int t) {
    return entry(t) ? entry(t)->max_shear_per_length.value_or(spec.max_shear_per_length)
                    : spec.max_shear_per_length;
  };
  const std::function<double(int)> cutting = [&](int t) {
    return entry(t) ? entry(t)->cutting_force.value_or(spec.cutting_force) : spec.cutting_force;
  };
  if (spec.friction == NeedleSpec::Friction::stick_slip)
    o.shear_profile = path_profile<dim>(lookup, shear, path, path.depth, spacing);
  if (dim == 3 && o.cuts()) o.cutting_profile = path_profile<dim>(lookup, cutting, path, path.depth, spacing);
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

template std::function<int(const Eigen::Vector2d&)> tissue_lookup<2>(
    const NeedleSpec&, const std::function<fem::Region<2>(const RegionSpec&)>&,
    const std::function<double(const Eigen::Vector2d&)>&);
template std::function<int(const Eigen::Vector3d&)> tissue_lookup<3>(
    const NeedleSpec&, const std::function<fem::Region<3>(const RegionSpec&)>&,
    const std::function<double(const Eigen::Vector3d&)>&);
template std::vector<int> point_tissues<2>(const std::function<int(const Eigen::Vector2d&)>&,
                                           const std::vector<Eigen::Vector2d>&);
template std::vector<int> point_tissues<3>(const std::function<int(const Eigen::Vector3d&)>&,
                                           const std::vector<Eigen::Vector3d>&);
template void set_path_values<2>(const NeedleSpec&, const std::function<int(const Eigen::Vector2d&)>&,
                                 const needle::NeedlePath<2>&, double, needle::FrictionOptions&);
template void set_path_values<3>(const NeedleSpec&, const std::function<int(const Eigen::Vector3d&)>&,
                                 const needle::NeedlePath<3>&, double, needle::FrictionOptions&);
template needle::NeedleOptions<2> needle_options<2>(const NeedleSpec&, const WorldTransform<2>&, int);
template needle::NeedleOptions<3> needle_options<3>(const NeedleSpec&, const WorldTransform<3>&, int);

}  // namespace vim::pipeline

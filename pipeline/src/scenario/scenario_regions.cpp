// Scenario regions as frame predicates (scenario_regions.hpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vim/pipeline/scenario/scenario_regions.hpp>

namespace vim::pipeline {

template <int dim>
fem::Region<dim> scenario_region(const RegionSpec& r, const Eigen::Matrix<double, dim, 1>& box_min,
                                 const Eigen::Matrix<double, dim, 1>& box_max, const WorldTransform<dim>& tf,
                                 const Image<dim>* labels) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  if (r.kind == RegionSpec::Kind::label) {
    if (!labels) throw std::invalid_argument("region " + r.describe() + " needs a label image (--labels)");
    const int value = r.label_value;
    return {r.describe(), [labels, value](const Vec& x) {
              const Vec c = labels->continuous_index(x);
              typename Image<dim>::Index i;
              for (int a = 0; a < dim; ++a)
                i[a] = std::lround(std::clamp(c[a], 0.0, static_cast<double>(labels->size[a] - 1)));
              return static_cast<int>(labels->at(i)) == value;
            }};
  }
  if (r.kind == RegionSpec::Kind::box_face) {
    const double tol = 1e-6 * (box_max - box_min).norm();
    return fem::box_face_region<dim>(box_min, box_max, r.axis, r.upper, tol);
  }
  std::function<bool(const Vec&)> world;
  if (r.kind == RegionSpec::Kind::box) {
    world = fem::box_region<dim>(spec_vector<dim>(r.lo), spec_vector<dim>(r.hi)).contains;
  } else if (r.kind == RegionSpec::Kind::sphere) {
    world = fem::sphere_region<dim>(spec_vector<dim>(r.center), r.radius).contains;
  } else {
    world = fem::cylinder_region<dim>(spec_vector<dim>(r.center), spec_vector<dim>(r.axis_vector), r.radius,
                                      r.length)
                .contains;
  }
  return {r.describe(), [world, tf](const Vec& x) { return world(tf.to_world(x)); }};
}

template fem::Region<2> scenario_region<2>(const RegionSpec&, const Eigen::Vector2d&, const Eigen::Vector2d&,
                                           const WorldTransform<2>&, const Image<2>*);
template fem::Region<3> scenario_region<3>(const RegionSpec&, const Eigen::Vector3d&, const Eigen::Vector3d&,
                                           const WorldTransform<3>&, const Image<3>*);

}  // namespace vim::pipeline

// Where the conditions of an elastic model act: geometric regions (selectors in the model's
// coordinates) and the conditions defined on them — Dirichlet supports along any axes, surface
// loads and elastic volume supports. deal.II-free (docs/architecture.md, fem module).
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>
#include <string>
#include <vector>

namespace vim::fem {

template <int dim>
using Vec = Eigen::Matrix<double, dim, 1>;

// A geometric selector in the model's coordinates. A node (support point) belongs to the region
// when contains(x) is true; a boundary face belongs when all its vertices do.
template <int dim>
struct Region {
  std::string name;
  std::function<bool(const Vec<dim>&)> contains;
};

// Region helpers (tolerance `tol` in length units).
template <int dim>
Region<dim> box_face_region(const Vec<dim>& box_min, const Vec<dim>& box_max, int axis, bool upper,
                            double tol);
template <int dim>
Region<dim> sphere_region(const Vec<dim>& center, double radius);
template <int dim>
Region<dim> box_region(const Vec<dim>& lo, const Vec<dim>& hi);
// A cylinder (2D: a slab) about the line through `center` along `axis`: infinite when length is 0, else
// the part within length/2 of center along the axis.
template <int dim>
Region<dim> cylinder_region(const Vec<dim>& center, const Vec<dim>& axis, double radius, double length = 0.0);

// u_c = value_c on every support point in region, for each component c with components[c] true.
// If `function` is set it replaces `value`: u_c = function(x)_c (e.g. a linear field for patch tests).
// A DoF selected by several conditions takes the FIRST condition added (and counts for its reaction).
// `axes` (orthonormal columns; identity = the model's axes) turns the components into directions:
// axes.col(c)·u = value_c for each selected c, e.g. a support that slides along a face that is not
// normal to a model axis. A condition with other axes holds a support point only if no earlier
// condition holds any of its DoFs, and then holds all of them (its reaction sums all of them).
template <int dim>
struct DirichletBC {
  Region<dim> region;
  std::array<bool, dim> components = filled(true);
  Vec<dim> value = Vec<dim>::Zero();
  std::function<Vec<dim>(const Vec<dim>&)> function = {};
  Eigen::Matrix<double, dim, dim> axes = Eigen::Matrix<double, dim, dim>::Identity();
  static std::array<bool, dim> filled(bool b) {
    std::array<bool, dim> a;
    a.fill(b);
    return a;
  }
};

// Surface load on boundary faces inside `region`: traction vector t, plus pressure p along the
// inward normal (t_total = t - p·n, n the outward normal).
template <int dim>
struct SurfaceLoad {
  Region<dim> region;
  Vec<dim> traction = Vec<dim>::Zero();
  double pressure = 0.0;
};

// Elastic support (a Winkler foundation) inside a volume: adds the energy ½ k Σ_p w_p |u(x_p) − b_p|², a
// quadrature of ½ ∫_R k |u − b|² dx over the sample points x_p (weights w_p in volume units): k w_p to
// the stiffness and, where the foundation's base has moved by b_p (`base`), the load k w_p b_p. Unlike a
// DirichletBC, which holds the nodes that happen to lie in a region, it does not depend on where the mesh
// puts its nodes: the same points, weights and k give every mesh (simplex or voxel) the same support, and a
// region that holds no node still holds the tissue. As k → ∞ the support tends to u = 0 on every cell that
// holds a sample point. Points outside the mesh are ignored (counted in n_outside after the first solve).
// Serial solves only (not solve_distributed).
template <int dim>
struct VolumeSupport {
  std::string name;
  std::vector<Vec<dim>> points;
  std::vector<double> weights;  // one per point (volume each point stands for)
  double stiffness = 0.0;       // k > 0: force per length^(dim+1) (modulus per length²)
  // The base's displacement b_p at each point (empty: at rest); ElasticModel::set_volume_support_base
  // moves it later as a change of the load alone (the factorisation and the cached columns stay).
  std::vector<Vec<dim>> base;
};

}  // namespace vim::fem

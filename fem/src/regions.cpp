// Geometric selectors for boundary conditions and loads: box faces, spheres, boxes and infinite
// cylinders, in the model's physical coordinates.
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/fem/conditions.hpp>

namespace vim::fem {

template <int dim>
Region<dim> box_face_region(const Vec<dim>& box_min, const Vec<dim>& box_max, int axis, bool upper,
                            double tol) {
  if (axis < 0 || axis >= dim) {
    std::ostringstream m;
    m << "box_face_region: axis " << axis << " is not in [0, " << dim - 1 << "]";
    throw std::invalid_argument(m.str());
  }
  if (!(tol >= 0.0))
    throw std::invalid_argument("box_face_region: tolerance must be >= 0, got " + std::to_string(tol));
  const double plane = upper ? box_max[axis] : box_min[axis];
  std::ostringstream name;
  name << "xyz"[axis] << (upper ? "_max" : "_min");
  return {name.str(), [plane, axis, tol](const Vec<dim>& x) { return std::abs(x[axis] - plane) <= tol; }};
}

template <int dim>
Region<dim> sphere_region(const Vec<dim>& center, double radius) {
  if (!(radius > 0.0))
    throw std::invalid_argument("sphere_region: radius must be > 0, got " + std::to_string(radius));
  return {"sphere", [center, radius](const Vec<dim>& x) { return (x - center).norm() <= radius; }};
}

template <int dim>
Region<dim> box_region(const Vec<dim>& lo, const Vec<dim>& hi) {
  for (int d = 0; d < dim; ++d)
    if (!(lo[d] <= hi[d]))
      throw std::invalid_argument("box_region: lo must be <= hi on every axis (axis " + std::to_string(d) +
                                  ")");
  return {"box", [lo, hi](const Vec<dim>& x) {
            for (int d = 0; d < dim; ++d)
              if (x[d] < lo[d] || x[d] > hi[d]) return false;
            return true;
          }};
}

template <int dim>
Region<dim> cylinder_region(const Vec<dim>& center, const Vec<dim>& axis, double radius, double length) {
  if (!(radius > 0.0))
    throw std::invalid_argument("cylinder_region: radius must be > 0, got " + std::to_string(radius));
  const double n = axis.norm();
  if (!(n > 0.0) || !std::isfinite(n))
    throw std::invalid_argument("cylinder_region: axis must be a non-zero finite vector");
  if (!(length >= 0.0) || !std::isfinite(length))
    throw std::invalid_argument("cylinder_region: length must be >= 0 (0: infinite), got " +
                                std::to_string(length));
  const Vec<dim> a = axis / n;
  return {"cylinder", [center, a, radius, length](const Vec<dim>& x) {
            const Vec<dim> r = x - center;
            const double along = r.dot(a);
            return (r - along * a).norm() <= radius && (length == 0.0 || std::abs(along) <= 0.5 * length);
          }};
}

#define VIM_FEM_REGIONS(dim)                                                                      \
  template Region<dim> box_face_region<dim>(const Vec<dim>&, const Vec<dim>&, int, bool, double); \
  template Region<dim> sphere_region<dim>(const Vec<dim>&, double);                               \
  template Region<dim> box_region<dim>(const Vec<dim>&, const Vec<dim>&);                         \
  template Region<dim> cylinder_region<dim>(const Vec<dim>&, const Vec<dim>&, double, double);
VIM_FEM_REGIONS(2)
VIM_FEM_REGIONS(3)

}  // namespace vim::fem

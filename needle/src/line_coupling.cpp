// The line coupling of a thin needle (vim/needle/line_coupling.hpp).
#include <vim/needle/line_coupling.hpp>

namespace vim::needle {

template <int dim>
LineCoupling<dim>::LineCoupling(std::vector<Vec> positions, const Vec& axis, const Mat& axes)
    : lateral_(positions.size(), Vec::Zero()), axis_(axis), axes_(axes) {
  for (const Vec& x : positions) {
    points_.emplace_back(x);
    points_.back().axes = axes;
  }
}

template <int dim>
void LineCoupling<dim>::held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                                    std::vector<Vec>& held) const {
  held.resize(active.size());
  for (std::size_t i = 0; i < active.size(); ++i)
    held[i] = axes_.transpose() * (axial[active[i]] * axis_ + lateral_[active[i]]);
}

template <int dim>
std::vector<double> LineCoupling<dim>::axial_forces(const std::vector<std::size_t>& active,
                                                    const fem::Solution<dim>& solution) const {
  std::vector<double> f(points_.size(), 0.0);
  for (std::size_t i = 0; i < active.size() && i < solution.point_force.size(); ++i)
    f[active[i]] = solution.point_force[i].dot(axis_);
  return f;
}

// The needle enters tissue the loads have already moved, so a picked-up point keeps the loads' lateral
// displacement rather than being pulled back to its rest line, which would load the needle with the
// loads' deformation (a rigid motion of the body would then change the needle forces). The
// displacement the needle itself causes ahead of the tip is not kept: the point joins on its line.
template <int dim>
std::vector<typename LineCoupling<dim>::Vec> LineCoupling<dim>::displacements(
    const std::vector<std::size_t>& points, const fem::ElasticModel<dim>& model) const {
  std::vector<Vec> at;
  at.reserve(points.size());
  for (std::size_t j : points) at.push_back(points_[j].position);
  return model.sample(at);
}

template <int dim>
void LineCoupling<dim>::keep_offsets(const std::vector<Vec>& u) {
  for (std::size_t j = 0; j < points_.size() && j < u.size(); ++j)
    lateral_[j] = u[j] - u[j].dot(axis_) * axis_;
}

template class LineCoupling<2>;
template class LineCoupling<3>;

}  // namespace vim::needle

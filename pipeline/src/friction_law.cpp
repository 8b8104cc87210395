// The needle-coupling pieces shared by every law (needle_coupling.hpp): the shaft state's compact
// views, the line coupling of a thin needle, and the choice of the friction law of a needle.
#include <vim/pipeline/needle_coupling.hpp>

#include "friction_laws.hpp"

namespace vim::pipeline {

Eigen::VectorXd ShaftState::compact(const std::vector<double>& v) const {
  Eigen::VectorXd c(static_cast<Eigen::Index>(active.size()));
  for (std::size_t i = 0; i < active.size(); ++i) c[static_cast<Eigen::Index>(i)] = v[active[i]];
  return c;
}

void ShaftState::expand(const Eigen::VectorXd& c, std::vector<double>& v) const {
  for (std::size_t i = 0; i < active.size(); ++i) v[active[i]] = c[static_cast<Eigen::Index>(i)];
}

std::unique_ptr<FrictionLaw> make_friction_law(const NeedleSpec& spec, int max_active_set_iterations) {
  if (spec.model == NeedleSpec::Model::force) return make_force_law(spec);
  if (spec.friction == NeedleSpec::Friction::stick_slip)
    return make_stick_slip_law(spec, max_active_set_iterations);
  return make_stick_law(spec);
}

template <int dim>
LineCoupling<dim>::LineCoupling(std::vector<Vec> positions, const Vec& axis, const Mat& axes)
    : positions_(std::move(positions)), lateral_(positions_.size(), Vec::Zero()), axis_(axis), axes_(axes) {}

template <int dim>
std::vector<fem::PointConstraint<dim>> LineCoupling<dim>::rows(const std::vector<std::size_t>& active,
                                                               const std::vector<double>& axial) const {
  std::vector<fem::PointConstraint<dim>> pts;
  pts.reserve(active.size());
  for (std::size_t j : active) {
    fem::PointConstraint<dim> p;
    p.position = positions_[j];
    p.axes = axes_;
    p.displacement = axes_.transpose() * (axial[j] * axis_ + lateral_[j]);
    pts.push_back(p);
  }
  return pts;
}

template <int dim>
std::vector<double> LineCoupling<dim>::axial_forces(const std::vector<std::size_t>& active,
                                                    const fem::Solution<dim>& solution) const {
  std::vector<double> f(positions_.size(), 0.0);
  for (std::size_t i = 0; i < active.size() && i < solution.point_force.size(); ++i)
    f[active[i]] = solution.point_force[i].dot(axis_);
  return f;
}

// The needle enters tissue the loads have already moved, so a picked-up point keeps the loads' lateral
// displacement rather than being pulled back to its rest line, which would load the needle with the
// loads' deformation (a rigid motion of the body would then change the needle forces). The
// displacement the needle itself causes ahead of the tip is not kept: the point joins on its line.
template <int dim>
void LineCoupling<dim>::keep_offsets(const std::vector<Vec>& u) {
  for (std::size_t j = 0; j < positions_.size() && j < u.size(); ++j)
    lateral_[j] = u[j] - u[j].dot(axis_) * axis_;
}

template class LineCoupling<2>;
template class LineCoupling<3>;

}  // namespace vim::pipeline

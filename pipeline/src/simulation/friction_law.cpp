// The needle-coupling pieces shared by every law (needle_coupling.hpp): the shaft state's compact
// views, the line coupling of a thin needle, the active set of the kinematic laws and the choice of the
// friction law of a needle.
#include <algorithm>
#include <cmath>
#include <vim/pipeline/simulation/needle_coupling.hpp>

#include "simulation/friction_laws.hpp"

namespace vim::pipeline {

Eigen::VectorXd ShaftState::compact(const std::vector<double>& v) const {
  Eigen::VectorXd c(static_cast<Eigen::Index>(active.size()));
  for (std::size_t i = 0; i < active.size(); ++i) c[static_cast<Eigen::Index>(i)] = v[active[i]];
  return c;
}

void ShaftState::expand(const Eigen::VectorXd& c, std::vector<double>& v) const {
  for (std::size_t i = 0; i < active.size(); ++i) v[active[i]] = c[static_cast<Eigen::Index>(i)];
}

// The active-set problem of the kinematic laws on the axial map: a point sticks (moves with the needle)
// unless its axial load exceeds its limit; then it slides, its value solved so that its load equals
// ±limit. A sliding point whose limit would need it to move ahead of the needle sticks again. One
// solve when every point can stick; the map (m + 1 solves when m changes) otherwise.
FrictionStep settle_active_set(ShaftState& state, TissueResponse& tissue, const std::vector<double>& limit,
                               std::vector<bool>& sliding, std::vector<double>& sign, int max_sweeps) {
  const auto exceeds = [](double force, double lim) { return std::abs(force) > lim * (1.0 + 1e-9); };
  // Try sticking first (sliding points keep their slipped value; an unlimited point never slides).
  for (std::size_t j : state.active) {
    if (!std::isfinite(limit[j])) sliding[j] = false;
    if (!sliding[j]) state.stick_to_needle(j);
  }
  bool need = false;
  for (std::size_t j : state.active) need = need || sliding[j];
  if (!need) {
    const std::vector<double> fa = tissue.solve(state.axial);
    for (std::size_t j : state.active) need = need || exceeds(fa[j], limit[j]);
  }
  if (!need) return {};
  const AxialMap& map = tissue.axial_map();
  const std::size_t m = state.active.size();
  Eigen::VectorXd wc = state.compact(state.axial), ws = state.compact(state.stick),
                  lim = state.compact(limit);
  std::vector<bool> sl(m);
  Eigen::VectorXd sg(m);
  for (std::size_t i = 0; i < m; ++i) {
    sl[i] = sliding[state.active[i]];
    sg[i] = sign[state.active[i]];
  }
  FrictionStep step;
  step.settled = false;
  for (; step.sweeps < std::max(1, max_sweeps) && !step.settled; ++step.sweeps) {
    map.solve_free(wc, sl, sg.cwiseProduct(lim));
    const Eigen::VectorXd f = map(wc);
    bool changed = false;
    for (std::size_t i = 0; i < m; ++i) {
      if (!sl[i] && exceeds(f[i], lim[i])) {
        sl[i] = true;
        sg[i] = f[i] > 0.0 ? 1.0 : -1.0;
        changed = true;
      } else if (sl[i] && (wc[i] - ws[i]) * sg[i] > 1e-12 * std::max(1.0, std::abs(ws[i]))) {
        sl[i] = false;
        wc[i] = ws[i];
        changed = true;
      }
    }
    step.settled = !changed;
  }
  state.expand(wc, state.axial);
  for (std::size_t i = 0; i < m; ++i) {
    sliding[state.active[i]] = sl[i];
    sign[state.active[i]] = sg[i];
  }
  tissue.solve(state.axial);
  return step;
}

std::unique_ptr<FrictionLaw> make_friction_law(const NeedleSpec& spec, int max_active_set_iterations) {
  if (spec.model == NeedleSpec::Model::force) return make_force_law(spec);
  if (spec.friction == NeedleSpec::Friction::stick_slip)
    return make_stick_slip_law(spec, max_active_set_iterations);
  return make_stick_law(spec, max_active_set_iterations);
}

template <int dim>
std::vector<fem::PointConstraint<dim>> NeedleCoupling<dim>::rows(const std::vector<std::size_t>& active,
                                                                 const std::vector<double>& axial) const {
  std::vector<Vec> held;
  held_values(active, axial, held);
  std::vector<fem::PointConstraint<dim>> pts;
  pts.reserve(active.size());
  for (std::size_t i = 0; i < active.size(); ++i) {
    pts.push_back(row_template(active[i]));
    pts.back().displacement = held[i];
  }
  return pts;
}

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

template class NeedleCoupling<2>;
template class NeedleCoupling<3>;
template class LineCoupling<2>;
template class LineCoupling<3>;

}  // namespace vim::pipeline

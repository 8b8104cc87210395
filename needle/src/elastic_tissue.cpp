// The linear elastic model behind the tissue interface (vim/needle/elastic_tissue.hpp).
#include <chrono>
#include <vim/needle/elastic_tissue.hpp>

namespace vim::needle {

using Clock = std::chrono::steady_clock;

template <int dim>
ElasticTissue<dim>::ElasticTissue(fem::ElasticModel<dim>& model, const NeedleCoupling<dim>& coupling,
                                  const ShaftState& state, std::size_t n_points, double probe_step,
                                  const fem::SolverOptions& solver, bool monolithic)
    : ModelTissue<dim>(model, coupling, state, n_points),
      probe_step_(probe_step),
      solver_(solver),
      monolithic_(monolithic) {}

template <int dim>
ElasticTissue<dim>::~ElasticTissue() = default;

template <int dim>
void ElasticTissue<dim>::precompute(const std::vector<Vec<dim>>& probes) {
  if (monolithic_) return;
  std::vector<fem::PointConstraint<dim>> rows;
  for (std::size_t j = 0; j < n_points_; ++j) rows.push_back(coupling_.row_template(j));
  rows.insert(rows.end(), held_rows_.begin(), held_rows_.end());
  condensed_ = std::make_unique<fem::CondensedConstraints<dim>>(model_, rows, probes, solver_);
}

// One solve of the step: the monolithic reference forms the whole field; the condensed rows give the
// point forces (and the probes' displacements) only, the field is formed when a step needs it.
template <int dim>
const std::vector<double>& ElasticTissue<dim>::solve(const std::vector<double>& axial) {
  const auto t = Clock::now();
  if (monolithic_) {
    std::vector<fem::PointConstraint<dim>> rows = coupling_.rows(state_.active, axial);
    rows.insert(rows.end(), held_rows_.begin(), held_rows_.end());
    solution_ = model_.solve_monolithic(rows, solver_);
  } else {
    coupling_.held_values(state_.active, axial, held_);
    active_ = state_.active;
    for (std::size_t i = 0; i < held_rows_.size(); ++i) {
      active_.push_back(n_points_ + i);
      held_.push_back(held_rows_[i].displacement);
    }
    condensed_->solve(active_, held_);
    condensed_->point_forces(solution_.point_force);
    solution_.stats = condensed_->stats();
  }
  // The shaft's rows' forces; the held rows' come after them.
  held_forces_.assign(solution_.point_force.begin() + static_cast<long>(state_.active.size()),
                      solution_.point_force.end());
  solution_.point_force.resize(state_.active.size());
  field_ = monolithic_;
  this->count_solve(t);
  forces_ = coupling_.axial_forces(state_.active, solution_);
  return forces_;
}

template <int dim>
fem::Solution<dim> ElasticTissue<dim>::whole_field() {
  return condensed_->field();
}

template <int dim>
void ElasticTissue<dim>::clear() {
  solution_ = fem::Solution<dim>{};
  field_ = true;
}

template <int dim>
const AxialMap& ElasticTissue<dim>::axial_map() {
  if (map_active_ == state_.active) return map_;
  map_ = probe_axial_map(*this, state_, n_points_, probe_step_);
  map_active_ = state_.active;
  return map_;
}

template <int dim>
double ElasticTissue<dim>::held_axial(std::size_t j, const Vec<dim>& axis) const {
  if (condensed_) return condensed_->held_displacement(j).dot(axis);
  return coupling_.displacements({j}, model_)[0].dot(axis);
}

template <int dim>
std::vector<Vec<dim>> ElasticTissue<dim>::probe_displacements(const std::vector<Vec<dim>>& probes) const {
  return condensed_ ? condensed_->probe_displacements() : model_.sample(probes);
}

template class ElasticTissue<2>;
template class ElasticTissue<3>;

}  // namespace vim::needle

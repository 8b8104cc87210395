// The neo-Hookean model behind the tissue interface (vim/needle/neo_hookean_tissue.hpp).
#include <chrono>
#include <vim/needle/neo_hookean_tissue.hpp>

namespace vim::needle {

using Clock = std::chrono::steady_clock;
using detail::seconds_since;

template <int dim>
NeoHookeanTissue<dim>::NeoHookeanTissue(fem::ElasticModel<dim>& model, const NeedleCoupling<dim>& coupling,
                                        const ShaftState& state, std::size_t n_points,
                                        const fem::NewtonOptions& newton)
    : ModelTissue<dim>(model, coupling, state, n_points), newton_(newton) {}

template <int dim>
NeoHookeanTissue<dim>::~NeoHookeanTissue() = default;

template <int dim>
void NeoHookeanTissue<dim>::precompute(const std::vector<Vec<dim>>& probes) {
  std::vector<fem::PointConstraint<dim>> rows;
  for (std::size_t j = 0; j < n_points_; ++j) rows.push_back(coupling_.row_template(j));
  rows_ = std::make_unique<fem::FiniteStrainRows<dim>>(model_, rows, probes, newton_);
}

template <int dim>
const std::vector<double>& NeoHookeanTissue<dim>::solve(const std::vector<double>& axial) {
  if (!rows_) precompute({});
  const auto t = Clock::now();
  coupling_.held_values(state_.active, axial, held_);
  rows_->solve(state_.active, held_);
  records_.push_back({rows_->steps(), rows_->halvings()});
  rows_->point_forces(solution_.point_force);
  solution_.stats = rows_->stats();
  field_ = false;
  map_current_ = false;
  solved_active_ = state_.active;
  axial_ = axial;
  loaded_rows_ = !state_.active.empty();
  this->count_solve(t);
  forces_ = coupling_.axial_forces(state_.active, solution_);
  return forces_;
}

// f(w) ≈ f(w₀) + K (w − w₀) about the last solve's values w₀: column j of K is the change of the
// axial forces for a unit change of point j's axial value, through the rows' held values (affine in
// the axial values) and the tangent's condensed compliance.
template <int dim>
const AxialMap& NeoHookeanTissue<dim>::axial_map() {
  if (solved_active_ != state_.active || !rows_) solve(state_.axial);
  if (map_current_) return map_;
  const auto t = Clock::now();
  const std::size_t m = state_.active.size();
  if (keep_map()) {
    map_.c = state_.compact(forces_) - map_.K * state_.compact(axial_);
    map_base_ = state_.compact(forces_);
    map_current_ = true;
    solve_seconds_ += seconds_since(t);
    return map_;
  }
  const auto mi = static_cast<Eigen::Index>(m);
  std::vector<double> shifted = axial_;
  std::vector<Vec<dim>> base;
  coupling_.held_values(state_.active, axial_, base);
  map_.K.resize(mi, mi);
  fem::Solution<dim> delta;
  for (std::size_t i = 0; i < m; ++i) {
    shifted[state_.active[i]] += 1.0;
    coupling_.held_values(state_.active, shifted, d_held_);
    shifted[state_.active[i]] -= 1.0;
    for (std::size_t k = 0; k < m; ++k) d_held_[k] -= base[k];
    rows_->linearised_forces(d_held_, delta.point_force);
    map_.K.col(static_cast<Eigen::Index>(i)) = state_.compact(coupling_.axial_forces(state_.active, delta));
  }
  map_.K = (0.5 * (map_.K + map_.K.transpose())).eval();
  map_.c = state_.compact(forces_) - map_.K * state_.compact(axial_);
  map_base_ = state_.compact(forces_);
  map_active_ = state_.active;
  map_current_ = true;
  solve_seconds_ += seconds_since(t);
  return map_;
}

// The kept map (made for the same active points) predicted the last solve's forces f from those where
// it was renewed, f₀: its miss max|f − (K w + c)| is at most kept_map_miss_ratio of max|f − f₀|.
template <int dim>
bool NeoHookeanTissue<dim>::keep_map() const {
  if (map_active_.empty() || map_active_ != state_.active) return false;
  const Eigen::VectorXd f = state_.compact(forces_);
  const Eigen::VectorXd predicted = map_.K * state_.compact(axial_) + map_.c;
  const double miss = (f - predicted).cwiseAbs().maxCoeff();
  return miss <= kept_map_miss_ratio * (f - map_base_).cwiseAbs().maxCoeff();
}

template <int dim>
fem::Solution<dim> NeoHookeanTissue<dim>::whole_field() {
  return rows_->field();
}

// No contact and no loads: the rows of an earlier solve released (the tissue back at rest).
template <int dim>
void NeoHookeanTissue<dim>::clear() {
  if (loaded_rows_) {
    const std::vector<std::size_t> none;
    const auto t = Clock::now();
    rows_->solve(none, {});
    records_.push_back({rows_->steps(), rows_->halvings()});
    this->count_solve(t);
    loaded_rows_ = false;
    solved_active_.clear();
    map_active_.clear();
    map_current_ = false;
  }
  solution_ = fem::Solution<dim>{};
  field_ = true;
}

template <int dim>
double NeoHookeanTissue<dim>::held_axial(std::size_t j, const Vec<dim>& axis) const {
  return rows_ ? rows_->held_displacement(j).dot(axis) : 0.0;
}

template <int dim>
std::vector<Vec<dim>> NeoHookeanTissue<dim>::probe_displacements(const std::vector<Vec<dim>>& probes) const {
  return rows_ ? rows_->probe_displacements() : std::vector<Vec<dim>>(probes.size(), Vec<dim>::Zero());
}

template <int dim>
std::vector<NewtonSolveRecord> NeoHookeanTissue<dim>::take_records() {
  std::vector<NewtonSolveRecord> r;
  r.swap(records_);
  return r;
}

template class NeoHookeanTissue<2>;
template class NeoHookeanTissue<3>;

}  // namespace vim::needle

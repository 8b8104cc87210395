// The tissue as a finite-element model behind the needle's rows: the tissue interface
// (TissueResponse) and what the pipeline's stepping reads of the model at each step — the whole field
// on request, the displacement the rows hold, the probes (targets, seeds) and the solve count.
// Implementations: the linear elastic model condensed once (ElasticTissue) and the neo-Hookean model
// solved by Newton per step (NeoHookeanTissue).
#pragma once

#include <chrono>
#include <cstddef>
#include <vector>
#include <vim/fem/model.hpp>
#include <vim/needle/coupling.hpp>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/shaft_state.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

namespace detail {
// Wall-clock seconds since `t` (the tissues' solve timings).
inline double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace detail

template <int dim>
class ModelTissue : public TissueResponse {
 public:
  // Before stepping: the rows of every shaft point and the probes (points whose displacement each
  // solve gives).
  virtual void precompute(const std::vector<Vec<dim>>& probes) = 0;
  // No contact: an empty solution that counts as formed.
  virtual void clear() = 0;
  // The displacement along `axis` that point j's rows hold in the last solution.
  virtual double held_axial(std::size_t j, const Vec<dim>& axis) const = 0;
  // The probes' displacements in the last solve.
  virtual std::vector<Vec<dim>> probe_displacements(const std::vector<Vec<dim>>& probes) const = 0;

  // The whole field of the last solve into solution() (once per solve): the point forces are the
  // shaft's active rows'.
  void form_field() {
    if (field_) return;
    const auto t = std::chrono::steady_clock::now();
    solution_ = whole_field();
    solution_.point_force.resize(state_.active.size());
    solve_seconds_ += detail::seconds_since(t);
    field_ = true;
  }
  fem::Solution<dim>& solution() { return solution_; }
  int solves() const { return solves_; }
  double solve_seconds() const { return solve_seconds_; }

 protected:
  // `state` is the stepping's (its active points are the rows of each solve); n_points: the shaft's.
  ModelTissue(fem::ElasticModel<dim>& model, const NeedleCoupling<dim>& coupling, const ShaftState& state,
              std::size_t n_points)
      : model_(model), coupling_(coupling), state_(state), n_points_(n_points) {}
  // The whole field of the last solve (form_field keeps it).
  virtual fem::Solution<dim> whole_field() = 0;
  // A solve that started at `t` done: its time and count.
  void count_solve(std::chrono::steady_clock::time_point t) {
    solve_seconds_ += detail::seconds_since(t);
    ++solves_;
  }

  fem::ElasticModel<dim>& model_;
  const NeedleCoupling<dim>& coupling_;
  const ShaftState& state_;
  std::size_t n_points_;
  fem::Solution<dim> solution_;
  bool field_ = false;  // solution_ holds the whole field of the last solve
  AxialMap map_;
  double solve_seconds_ = 0.0;

 private:
  int solves_ = 0;
};

}  // namespace vim::needle

// A needle left in (stay: true, docs/procedure.md): its rows held for the later actions, and its
// withdrawal by a later action from its last state (needle_insertion.hpp, withdraw_later).
#include <stdexcept>

#include "simulation/needle_insertion.hpp"

namespace vim::pipeline {

// Left in: its stations keep holding the tissue as this last step left it.
template <int dim>
void NeedleInsertion<dim>::leave_in() {
  const needle::ShaftState &state = stepping_->state();
  const auto rows = coupling_->rows(state.active, state.axial);
  ctx_.staying.insert(ctx_.staying.end(), rows.begin(), rows.end());
  ctx_.staying_needles.push_back({coupling_, state, rows.size()});
}

template <int dim>
void NeedleInsertion<dim>::release_hold() {
  std::size_t first = 0;
  for (auto it = ctx_.staying_needles.begin(); it != ctx_.staying_needles.end(); ++it) {
    if (it->coupling == coupling_) {
      const auto begin = ctx_.staying.begin() + static_cast<long>(first);
      ctx_.staying.erase(begin, begin + static_cast<long>(it->rows));
      ctx_.staying_needles.erase(it);
      return;
    }
    first += it->rows;
  }
  throw std::logic_error("withdraw_later: needle '" + spec_.name + "' is not left in");
}

template <int dim>
NeedleOutcome<dim> NeedleInsertion<dim>::withdraw_later(std::vector<NeedleRun<dim>> &runs,
                                                        std::size_t index) {
  const auto t_run = Clock::now();
  run_ = std::move(runs.at(index));
  release_hold();
  make_tissue(spec_);  // holds the needles still left in
  earlier_points_.clear();
  for (const auto &r : ctx_.released) earlier_points_.push_back(r.planned_frame);
  earlier_displacement_.assign(earlier_points_.size(), Vec::Zero());
  loaded_ = loaded();
  const int first = total_steps_ + 1;
  total_steps_ += spec_.withdraw_steps;
  precompute();
  if (stepping_->law().has_active_set())
    run_.active_set_sweeps.resize(static_cast<std::size_t>(total_steps_) + 1, 0);
  const auto t_steps = Clock::now();
  take_steps(first);
  run_.stepping_seconds += seconds_since(t_steps);
  // The seeds released since its insertion (by the later needles, in ctx_.released's order) end where
  // this withdrawal leaves the tissue.
  std::size_t j = 0;
  for (std::size_t n = 0; n < runs.size(); ++n)
    for (auto &seed : runs[n].seeds)
      if (n != index && seed.release_step >= 0 && j < earlier_displacement_.size())
        seed.rest_displacement = earlier_displacement_[j++];
  return finish(seconds_since(t_run));
}

#define VIM_NEEDLE_LEFT_IN(dim)                                                                   \
  template void NeedleInsertion<dim>::leave_in();                                                 \
  template void NeedleInsertion<dim>::release_hold();                                             \
  template NeedleOutcome<dim> NeedleInsertion<dim>::withdraw_later(std::vector<NeedleRun<dim>> &, \
                                                                   std::size_t);
VIM_NEEDLE_LEFT_IN(2)
VIM_NEEDLE_LEFT_IN(3)

}  // namespace vim::pipeline

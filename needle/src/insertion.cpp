// The insertion stepping of one needle (vim/needle/insertion.hpp).
#include <algorithm>
#include <vim/needle/insertion.hpp>

namespace vim::needle {

template <int dim>
Insertion<dim>::Insertion(const NeedleOptions<dim>& options, std::vector<ShaftPoint<dim>> shaft)
    : options_(options), shaft_(std::move(shaft)) {
  const std::size_t np = shaft_.size();
  start_.assign(np, 0.0);
  end_.assign(np, 0.0);
  for (std::size_t j = 0; j < np; ++j) {
    start_[j] = dim == 3 ? shaft_[j].s - 0.5 * shaft_[j].length
                : j > 0  ? start_[j - 1] + shaft_[j - 1].length
                         : 0.0;
    end_[j] = dim == 3 ? shaft_[j].s + 0.5 * shaft_[j].length : shaft_[j].s;
  }
  law_ = make_friction_law(options_.friction);
  law_->start(np);
  cuts_ = law_->tip_cuts();
  state_.joined.assign(np, false);
  state_.axial.assign(np, 0.0);
  state_.stick.assign(np, 0.0);
  state_.carried.assign(np, 0.0);
  picked_.assign(np, false);
  state_.active.reserve(np);  // steps allocate nothing (the real-time needle)
  state_.cutting = np;
}

template <int dim>
double Insertion<dim>::depth(int k) const {
  return options_.path.depth * static_cast<double>(k) / static_cast<double>(options_.steps);
}

template <int dim>
void Insertion<dim>::pick_up(double depth, double travel,
                             const std::function<double(std::size_t)>& held_axial) {
  const std::size_t np = shaft_.size();
  const double cut = depth - options_.friction.cutting_distance;
  const double eps = 1e-9 * options_.path.depth;
  std::fill(state_.stick.begin(), state_.stick.end(), 0.0);
  std::fill(state_.joined.begin(), state_.joined.end(), false);
  for (std::size_t j : state_.active) state_.stick[j] = state_.axial[j] + travel;
  // The point the tip pushed is cut once the tip has passed its band.
  if (state_.cutting < np && end_[state_.cutting] + held_axial(state_.cutting) < cut - eps)
    state_.cutting = np;
  for (std::size_t j = 0; j < np && state_.cutting == np && start_[j] < cut - eps; ++j) {
    if (picked_[j]) continue;
    const double ua = held_axial(j);
    if (start_[j] + ua >= cut - eps) break;  // the tip has not reached its band
    const bool passed = end_[j] + ua < cut - eps;
    if (!passed && !cuts_) break;  // tissue at the tip, cut without resistance: free
    state_.joined[j] = true;
    picked_[j] = true;
    state_.stick[j] = state_.axial[j] = cut - (passed ? end_[j] : start_[j]);
    if (!passed) state_.cutting = j;
  }
  state_.active.clear();
  state_.tip = np;
  for (std::size_t j = 0; j < np; ++j) {
    if (!picked_[j]) continue;
    state_.active.push_back(j);
    state_.tip = j;
  }
  for (std::size_t j : state_.active)
    state_.carried[j] = j == state_.tip ? depth - start_[j] : std::min(shaft_[j].length, depth - start_[j]);
}

template class Insertion<2>;
template class Insertion<3>;

}  // namespace vim::needle

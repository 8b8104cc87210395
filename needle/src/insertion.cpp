// The insertion stepping of one needle (vim/needle/insertion.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vim/needle/insertion.hpp>

namespace vim::needle {

template <int dim>
Insertion<dim>::Insertion(const NeedleOptions<dim>& options, std::vector<ShaftPoint<dim>> shaft,
                          std::vector<ShaftPoint<dim>> tip_rows)
    : options_(options), shaft_(std::move(shaft)), tips_(std::move(tip_rows)) {
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
  cuts_ = law_->tip_cuts();
  if (!cuts_ || dim == 2) tips_.clear();
  const std::size_t n = n_points();
  law_->start(n);
  state_.joined.assign(n, false);
  state_.axial.assign(n, 0.0);
  state_.stick.assign(n, 0.0);
  state_.carried.assign(n, 0.0);
  state_.start = start_;
  picked_.assign(n, false);
  state_.active.reserve(n);  // steps allocate nothing (the real-time needle)
  state_.cutting = n;
}

template <int dim>
double Insertion<dim>::depth(int k) const {
  return options_.path.depth * static_cast<double>(k) / static_cast<double>(options_.steps);
}

template <int dim>
void Insertion<dim>::pick_up(double depth, double travel,
                             const std::function<double(std::size_t)>& held_axial) {
  const double cut = depth - options_.friction.cutting_distance;
  cut_ = cut;
  std::fill(state_.stick.begin(), state_.stick.end(), 0.0);
  std::fill(state_.joined.begin(), state_.joined.end(), false);
  for (std::size_t j : state_.active) state_.stick[j] = state_.axial[j] + travel;
  if constexpr (dim == 2)
    pick_up_points(cut, depth, held_axial);
  else
    pick_up_bands(cut, travel, held_axial);
  list_active();
}

template <int dim>
void Insertion<dim>::list_active() {
  state_.active.clear();
  state_.tip = n_points();
  for (std::size_t j = 0; j < n_points(); ++j) {
    if (!picked_[j]) continue;
    state_.active.push_back(j);
    if (j < shaft_.size()) state_.tip = j;
  }
}

// 2D: a point joins once the tip has passed it; with a cutting force the point whose band the tip has
// entered is pushed (joined at cut − b_j) until it is cut. Positions are current ones, b_j + ū_j.
template <int dim>
void Insertion<dim>::pick_up_points(double cut, double depth,
                                    const std::function<double(std::size_t)>& held_axial) {
  const std::size_t np = shaft_.size();
  const double eps = 1e-9 * options_.path.depth;
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
  std::size_t last = np;
  for (std::size_t j = 0; j < np; ++j)
    if (picked_[j]) last = j;
  for (std::size_t j = 0; j < np; ++j)
    if (picked_[j])
      state_.carried[j] = j == last ? depth - start_[j] : std::min(shaft_[j].length, depth - start_[j]);
}

// 3D: the front (the tip's end bearing, or the tissue cut without resistance), then every station the
// front has entered carries its cut part at the mean stick value of that part.
template <int dim>
void Insertion<dim>::pick_up_bands(double cut, double travel,
                                   const std::function<double(std::size_t)>& held_axial) {
  const std::size_t np = shaft_.size();
  const double eps = 1e-9 * options_.path.depth;
  double reach = state_.front;  // the front the stations take
  if (!tips_.empty()) {
    reach = press_tip(cut, travel);
  } else {
    // The tissue at the tip: that of the first station not wholly cut (ū its band's mean).
    std::size_t jf = 0;
    while (jf < np && state_.carried[jf] >= shaft_[jf].length - eps) ++jf;
    const double u = jf < np ? held_axial(jf) : 0.0;
    reach = state_.front = std::max(state_.front, cut - u);
  }
  reach_ = reach;
  join_stations(cut, reach);
}

// Every station the front `reach` has entered carries its cut part at the mean stick value of that
// part (the part cut before keeps its value).
template <int dim>
void Insertion<dim>::join_stations(double cut, double reach) {
  const std::size_t np = shaft_.size();
  const double eps = 1e-9 * options_.path.depth;
  for (std::size_t j = 0; j < np && start_[j] < reach - eps; ++j) {
    const double old_length = state_.carried[j];
    const double new_length = std::max(old_length, std::min(shaft_[j].length, reach - start_[j]));
    if (new_length <= old_length + eps) continue;
    // The tissue cut at this step, [b_j + L_old, b_j + L_new], sticks at cut − s: its mean.
    const double fresh = cut - (start_[j] + 0.5 * (old_length + new_length));
    if (!picked_[j]) {
      picked_[j] = state_.joined[j] = true;
      state_.stick[j] = state_.axial[j] = fresh;
    } else {
      state_.stick[j] = (old_length * state_.stick[j] + (new_length - old_length) * fresh) / new_length;
    }
    state_.carried[j] = new_length;
  }
}

// The tip presses the tissue at the front through the disk row nearest it, at cut − f (the tip cuts
// nothing more unless the law holds the row at the cutting force, solve()). The stations take the
// front the tip reaches if it keeps cutting with the indentation of the last step (f + travel), so
// that the tissue cut in a step carries friction in that step; the front itself never runs ahead.
template <int dim>
double Insertion<dim>::press_tip(double cut, double travel) {
  const std::size_t np = shaft_.size();
  if (cut <= tips_.front().s) return state_.front;  // not in contact yet
  std::size_t& row = state_.cutting;
  // The prediction holds while the cutting force stays that of the tissue at the front: it does not
  // reach past the next change of the cutting force along the path, where solve() stops the cut (a tip
  // entering tissue with a higher cutting force presses it deeper first, and the stations would carry
  // uncut tissue). A tip that cut in the last step has the indentation of the tissue at its front.
  const PathProfile& fc = options_.friction.cutting_profile;
  const double ahead =
      fc.empty() ? state_.front + travel : std::min(state_.front + travel, fc.next_change(state_.front));
  const double reach = state_.tip_cutting ? ahead : state_.front;
  if (row == n_points()) state_.front = std::max(state_.front, tips_.front().s);
  std::size_t k = 0;
  for (std::size_t i = 1; i < tips_.size(); ++i)
    if (std::abs(tips_[i].s - state_.front) < std::abs(tips_[k].s - state_.front)) k = i;
  if (row != np + k) {
    if (row < n_points()) picked_[row] = false;
    row = np + k;
    picked_[row] = state_.joined[row] = true;
    state_.axial[row] = cut - state_.front;
  }
  state_.stick[row] = cut - state_.front;
  return std::max(reach, state_.front);
}

template <int dim>
void Insertion<dim>::withdraw(double depth, double travel) {
  const double cut = depth - options_.friction.cutting_distance;
  const double eps = 1e-9 * options_.path.depth;
  cut_ = cut;
  std::fill(state_.joined.begin(), state_.joined.end(), false);
  for (std::size_t j : state_.active) state_.stick[j] = state_.axial[j] + travel;
  if (state_.cutting < n_points()) {  // the tip presses nothing on the way out
    if (state_.cutting >= shaft_.size()) picked_[state_.cutting] = false;
    state_.cutting = n_points();
  }
  state_.tip_cutting = false;
  const auto leave = [&](std::size_t j) {
    picked_[j] = false;
    state_.axial[j] = state_.stick[j] = state_.carried[j] = 0.0;
  };
  for (std::size_t j = 0; j < shaft_.size(); ++j) {
    if (!picked_[j]) continue;
    if constexpr (dim == 3) {
      const double old_length = state_.carried[j];
      const double new_length = std::min(old_length, cut - start_[j]);
      if (new_length <= eps) {
        leave(j);
        continue;
      }
      state_.stick[j] += 0.5 * (old_length - new_length);
      state_.carried[j] = new_length;
    } else {
      if (cut <= end_[j] + eps) leave(j);
    }
  }
  state_.front = std::min(state_.front, cut);
  list_active();
  if constexpr (dim == 2)
    for (std::size_t j : state_.active)
      state_.carried[j] = j == state_.tip ? depth - start_[j] : std::min(shaft_[j].length, depth - start_[j]);
}

// After the law's solve: a tip row held at the cutting force (behind its stick value) has cut the
// tissue up to cut − w, w its value (the indentation).
template <int dim>
FrictionStep Insertion<dim>::solve(TissueResponse& tissue) {
  const double front = state_.front;  // the tissue the tip met at the step's start
  FrictionStep step = law_->update(state_, tissue);
  const std::size_t c = state_.cutting;
  state_.tip_cutting =
      c < n_points() && state_.axial[c] < state_.stick[c] - 1e-12 * std::max(1.0, std::abs(state_.stick[c]));
  if (state_.tip_cutting && c >= shaft_.size()) state_.front = std::max(state_.front, cut_ - state_.axial[c]);
  // The tip cut past the next change of the cutting force along the path: it cut at this tissue's force
  // only up to there, and presses the next tissue from there at that tissue's force (solved again).
  const PathProfile& fc = options_.friction.cutting_profile;
  const double boundary = fc.empty() ? std::numeric_limits<double>::infinity() : fc.next_change(front);
  if (dim == 3 && state_.tip_cutting && c >= shaft_.size() &&
      state_.front > boundary + 1e-9 * options_.path.depth) {
    state_.front = boundary;
    state_.stick[c] = cut_ - boundary;
    join_stations(cut_, boundary);
    reach_ = std::max(reach_, boundary);
    list_active();
    const FrictionStep again = law_->update(state_, tissue);
    step = {again.sweeps + step.sweeps, again.settled};
    state_.tip_cutting = state_.axial[c] < state_.stick[c] - 1e-12 * std::max(1.0, std::abs(state_.stick[c]));
    if (state_.tip_cutting) state_.front = std::max(state_.front, cut_ - state_.axial[c]);
  }
  // The tip cut past the front the stations took (it punctured in this step, or cut more than the last
  // step's indentation predicted): the tissue cut in this step joins now and the step is solved again,
  // so that it carries friction in the step that cut it.
  if (dim == 3 && state_.tip_cutting && c >= shaft_.size() &&
      state_.front > reach_ + 1e-9 * options_.path.depth) {
    join_stations(cut_, state_.front);
    list_active();
    const FrictionStep again = law_->update(state_, tissue);
    state_.tip_cutting = state_.axial[c] < state_.stick[c] - 1e-12 * std::max(1.0, std::abs(state_.stick[c]));
    if (state_.tip_cutting) state_.front = std::max(state_.front, cut_ - state_.axial[c]);
    return {again.sweeps + step.sweeps, again.settled};
  }
  return step;
}

template class Insertion<2>;
template class Insertion<3>;

}  // namespace vim::needle

// One needle inserted step by step (needle_insertion.hpp).
#include "simulation/needle_insertion.hpp"

#include <algorithm>
#include <limits>
#include <numeric>
#include <sstream>

#include "simulation/largest_strain.hpp"
#include "simulation/simulation_output.hpp"

namespace vim::pipeline {

template <int dim>
NeedleInsertion<dim>::NeedleInsertion(SimulationContext<dim>& context, const NeedleSpec& spec,
                                      std::string prefix, bool snap_to_vertices)
    : ctx_(context), spec_(spec), prefix_(std::move(prefix)) {
  axis_world_ = vec<dim>(spec.direction).normalized();
  entry_world_ = vec<dim>(spec.entry);
  make_coupling(needle_path<dim>(spec, ctx_.tf), snap_to_vertices);
  if (shaft_.empty())
    throw ScenarioError(
        ctx_.sc.where(spec.line) + "needle '" + spec.name +
        "': no point of its path lies in the free part of the mesh (is it inside a fixed region?)");
  const std::size_t np = shaft_.size();
  start_.assign(np, 0.0);
  end_.assign(np, 0.0);
  for (std::size_t j = 0; j < np; ++j) {
    start_[j] = dim == 3 ? shaft_[j].s - 0.5 * shaft_[j].length
                : j > 0  ? start_[j - 1] + shaft_[j - 1].length
                         : 0.0;
    end_[j] = dim == 3 ? shaft_[j].s + 0.5 * shaft_[j].length : shaft_[j].s;
  }
  cuts_ = spec.model == NeedleSpec::Model::kinematic && spec.cutting_force > 0.0;
  law_ = make_friction_law(spec, ctx_.opt.max_active_set_iterations);
  law_->start(np);
  for (const auto& t : ctx_.sc.targets) targets_.push_back(ctx_.tf.to_frame(vec<dim>(t.position)));
  // External loads (a prescribed displacement, a pressure, a traction) act from the start: before the
  // tip reaches the first shaft point (step 0 included) the tissue deforms under them alone, not rest.
  loaded_ = std::any_of(
      ctx_.sc.boundary_conditions.begin(), ctx_.sc.boundary_conditions.end(),
      [](const BoundaryConditionSpec& bc) { return bc.type != BoundaryConditionSpec::Type::fixed; });
  write_ = writes_steps(ctx_.opt) && ctx_.sc.output_every > 0;
  state_.joined.assign(np, false);
  state_.axial.assign(np, 0.0);
  state_.stick.assign(np, 0.0);
  state_.carried.assign(np, 0.0);
  picked_.assign(np, false);
  state_.cutting = np;
  run_.name = spec.name;
  run_.axis = axis_world_;
  for (const auto& p : shaft_) {
    run_.point_s.push_back(p.s);
    run_.point_length.push_back(p.length);
  }
}

// 3D: band stations, uniform along the path (needle.sample_spacing, else the element size h near the
// path: the mesh resolves the field along the shaft on that scale), coupling
// radius needle.coupling_radius or the default rule from the element size near the path. 2D: points on
// the axis (sample_shaft; a plane-strain needle is a blade, and a line converges in 2D).
template <int dim>
void NeedleInsertion<dim>::make_coupling(const NeedlePath<dim>& path, bool snap_to_vertices) {
  axis_ = path.axis;
  if constexpr (dim == 3) {
    const double h = fem::path_element_size(ctx_.locator(), path.entry, path.axis, spec_.depth);
    const auto with_spacing = [&](BandCoupling::Geometry geometry) {
      geometry.spacing = spec_.sample_spacing > 0.0 ? spec_.sample_spacing : h;
      return geometry;
    };
    BandCoupling::Geometry g;
    g.entry = path.entry;
    g.axis = path.axis;
    g.to_world = ctx_.tf.direction;
    g.depth = spec_.depth;
    g.radius = 0.5 * spec_.diameter;
    g.coupling_radius = spec_.coupling_radius;
    g.element_size = h;
    g.degree = ctx_.degree;
    auto band = std::make_unique<BandCoupling>(with_spacing(g), ctx_.locator(), ctx_.E, ctx_.sc.poisson_ratio,
                                               ctx_.blocked, ctx_.held_regions);
    // A mesh so coarse that no band of the default size fits in it (every sample outside): halve h.
    for (int k = 0; k < 8 && band->stations().empty() && spec_.coupling_radius <= 0.0; ++k) {
      g.element_size *= 0.5;
      band = std::make_unique<BandCoupling>(with_spacing(g), ctx_.locator(), ctx_.E, ctx_.sc.poisson_ratio,
                                            ctx_.blocked, ctx_.held_regions);
    }
    shaft_ = band->stations();
    pitch_ = shaft_.empty() ? with_spacing(g).spacing : shaft_.front().length;
    coupling_radius_ = band->coupling_radius();
    coupling_ = std::move(band);
  } else {
    pitch_ = spec_.sample_spacing > 0.0 ? spec_.sample_spacing : 0.5 * ctx_.locator().mean_edge_length();
    shaft_ = sample_shaft<dim>(ctx_.locator(), path.entry, axis_, spec_.depth, pitch_, ctx_.blocked,
                               snap_to_vertices);
    std::vector<Vec> positions;
    for (const auto& p : shaft_) positions.push_back(p.position);
    coupling_ = std::make_unique<LineCoupling<dim>>(std::move(positions), axis_, ctx_.point_axes);
  }
}

// One solve of the step: the monolithic reference forms the whole field; the condensed rows give the
// point forces (and the targets' displacements) only, the field is formed when a step needs it.
template <int dim>
std::vector<double> NeedleInsertion<dim>::solve(const std::vector<double>& axial) {
  const auto t = Clock::now();
  if (ctx_.opt.monolithic) {
    solution_ = ctx_.model->solve_monolithic(coupling_->rows(state_.active, axial), ctx_.solver);
  } else {
    coupling_->held_values(state_.active, axial, held_);
    condensed_->solve(state_.active, held_);
    condensed_->point_forces(solution_.point_force);
    solution_.stats = condensed_->stats();
  }
  field_ = ctx_.opt.monolithic;
  solve_seconds_ += seconds_since(t);
  ++solves_;
  return coupling_->axial_forces(state_.active, solution_);
}

template <int dim>
void NeedleInsertion<dim>::form_field() {
  if (field_) return;
  const auto t = Clock::now();
  solution_ = condensed_->field();
  solve_seconds_ += seconds_since(t);
  field_ = true;
}

template <int dim>
const AxialMap& NeedleInsertion<dim>::axial_map() {
  if (map_size_ == state_.active.size()) return map_;
  map_ = AxialMap::probe(
      static_cast<Eigen::Index>(state_.active.size()),
      [&](const Eigen::VectorXd& wc) {
        std::vector<double> full(shaft_.size(), 0.0);
        state_.expand(wc, full);
        return state_.compact(solve(full));
      },
      pitch_);
  map_size_ = state_.active.size();
  return map_;
}

template <int dim>
NeedleRun<dim> NeedleInsertion<dim>::run(nlohmann::json& report) {
  Progress progress("needle " + spec_.name, spec_.steps);
  const auto t_run = Clock::now();
  precompute();
  rest();
  if (law_->has_active_set()) run_.active_set_sweeps.assign(static_cast<std::size_t>(spec_.steps) + 1, 0);
  const auto t_steps = Clock::now();
  for (int k = 1; k <= spec_.steps; ++k) {
    advance_one_step(k);
    if (ctx_.opt.progress) {
      std::ostringstream msg;
      msg << "step " << k << "/" << spec_.steps << ", depth " << run_.depth.back() << " "
          << ctx_.sc.length_unit << ", axial force " << run_.axial_force.back() << ", "
          << state_.active.size() << " shaft points";
      progress.report(k, msg.str());
    }
  }
  run_.stepping_seconds = seconds_since(t_steps);
  const double run_seconds = seconds_since(t_run);
  run_.solve_seconds = solve_seconds_;
  run_.steps_per_second = run_seconds > 0.0 ? spec_.steps / run_seconds : 0.0;
  if (ctx_.opt.output_file) {
    if (write_) write_pvd(ctx_.opt.output_file(prefix_ + "simulation.pvd"), pvd_);
    write_needle_csv<dim>(ctx_.opt.output_file(prefix_ + "needle.csv"), run_, ctx_.sc);
  }
  report = needle_report<dim>(spec_, run_, *law_, pitch_, prefix_, run_seconds, solves_, ctx_.opt.monolithic,
                              ctx_.sc);
  if (dim == 3) report["coupling_radius"] = coupling_radius_;
  return std::move(run_);
}

// Before stepping: the rows of every shaft point and their columns K⁻¹cᵀ in one batch, so that no step
// does a sparse solve (the monolithic reference solves each step from scratch).
template <int dim>
void NeedleInsertion<dim>::precompute() {
  if (ctx_.opt.monolithic) return;
  const auto t = Clock::now();
  std::vector<fem::PointConstraint<dim>> rows;
  for (std::size_t j = 0; j < shaft_.size(); ++j) rows.push_back(coupling_->row_template(j));
  condensed_ = std::make_unique<fem::CondensedConstraints<dim>>(*ctx_.model, rows, targets_, ctx_.solver);
  run_.precompute_seconds = seconds_since(t);
}

// Step 0: rest, or the external loads alone; their displacement across the axis at the shaft points
// is kept by the coupling.
template <int dim>
void NeedleInsertion<dim>::rest() {
  if (loaded_) {
    solve(state_.axial);
    form_field();
    std::vector<std::size_t> all(shaft_.size());
    for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
    coupling_->keep_offsets(coupling_->displacements(all, *ctx_.model));
  }
  have_solution_ = loaded_;
  record(0.0, loaded_ ? &solution_ : nullptr, loaded_ ? 1 : 0);
  record_field(loaded_ ? &solution_ : nullptr, false);
  run_.step_seconds.push_back(0.0);
  if (write_) output_step(0, loaded_ ? &solution_ : nullptr);
}

template <int dim>
void NeedleInsertion<dim>::advance_one_step(int k) {
  const double d = spec_.depth * static_cast<double>(k) / static_cast<double>(spec_.steps);
  const double d_prev = run_.depth.back();
  const int solves_before = solves_;
  const auto t_step = Clock::now();
  pick_up(d, d - d_prev);
  if (state_.active.empty()) {
    // The tip has not reached the first embedded point yet: the needle does not touch the tissue.
    if (loaded_)
      solve(state_.axial);
    else
      solution_ = fem::Solution<dim>{}, field_ = true;
    record(d, loaded_ ? &solution_ : nullptr, solves_ - solves_before);
  } else {
    const FrictionStep step = law_->update(state_, *this);
    if (law_->has_active_set()) {
      run_.active_set_sweeps[static_cast<std::size_t>(k)] = step.sweeps;
      if (!step.settled) run_.unsettled_steps.push_back(k);
    }
    record(d, &solution_, solves_ - solves_before);
  }
  have_solution_ = !state_.active.empty() || loaded_;
  run_.stats = solution_.stats;
  const bool written = write_ && (k % ctx_.sc.output_every == 0 || k == spec_.steps);
  if (have_solution_ && (ctx_.opt.step_fields || written || k == spec_.steps)) {
    form_field();
    record_field(&solution_, false);
  } else {
    record_field(nullptr, have_solution_);
  }
  run_.step_seconds.push_back(seconds_since(t_step));
  if (written) output_step(k, state_.active.empty() && !loaded_ ? nullptr : &solution_);
}

template <int dim>
double NeedleInsertion<dim>::axial_displacement(std::size_t j) const {
  if (!have_solution_) return 0.0;
  if (condensed_) return condensed_->held_displacement(j).dot(axis_);
  return coupling_->displacements({j}, *ctx_.model)[0].dot(axis_);
}

// The active set of the step at needle travel `depth` (`travel` since the last step): the stations
// joined before, the cutting station the tip pushes (if any) and those the tip reaches now, with the
// value that moves each with the needle and the shaft length each carries (see needle_insertion.hpp).
template <int dim>
void NeedleInsertion<dim>::pick_up(double depth, double travel) {
  const std::size_t np = shaft_.size();
  const double cut = depth - spec_.cutting_distance;
  const double eps = 1e-9 * spec_.depth;
  std::fill(state_.stick.begin(), state_.stick.end(), 0.0);
  std::fill(state_.joined.begin(), state_.joined.end(), false);
  for (std::size_t j : state_.active) state_.stick[j] = state_.axial[j] + travel;
  // The station the tip pushed is cut once the tip has passed its band.
  if (state_.cutting < np && end_[state_.cutting] + axial_displacement(state_.cutting) < cut - eps)
    state_.cutting = np;
  for (std::size_t j = 0; j < np && state_.cutting == np && start_[j] < cut - eps; ++j) {
    if (picked_[j]) continue;
    const double ua = axial_displacement(j);
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

// Needle force F = −Σ point forces (the force the tissue exerts on the needle), world axes; axial =
// −F·a (insertion resistance, > 0 when the tissue resists) and lateral = |F − (F·a)a|.
template <int dim>
void NeedleInsertion<dim>::record(double depth, const fem::Solution<dim>* s, int solves) {
  run_.depth.push_back(depth);
  run_.tip.push_back(entry_world_ + depth * axis_world_);
  Vec f = Vec::Zero();
  if (s)
    for (const auto& pf : s->point_force) f -= pf;
  f = ctx_.tf.vector_to_world(f);
  run_.force.push_back(f);
  const double ax = f.dot(axis_world_);
  run_.axial_force.push_back(0.0 - ax);  // +0 at rest
  run_.lateral_force.push_back((f - ax * axis_world_).norm());
  std::vector<Vec> td(targets_.size(), Vec::Zero());
  if (s && !targets_.empty()) {
    const auto u = coupling_->tissue_displacements(
        targets_, condensed_ ? condensed_->probe_displacements() : ctx_.model->sample(targets_), state_, *s);
    for (std::size_t t = 0; t < u.size(); ++t) td[t] = ctx_.tf.vector_to_world(u[t]);
  }
  run_.target_displacement.push_back(td);
  std::vector<double> pa(shaft_.size(), 0.0);
  if (s) pa = coupling_->axial_forces(state_.active, *s);
  // The axial force splits into the shaft's friction and the force on the tissue the tip pushes (the
  // cutting station; the force model: the tip point, which carries tip_force).
  const std::size_t pushed = spec_.model == NeedleSpec::Model::force ? state_.tip : state_.cutting;
  double friction = 0.0;
  for (std::size_t j : state_.active)
    if (j != pushed) friction += pa[j];
  run_.friction_force.push_back(s ? friction : 0.0);
  run_.tip_force.push_back(s && pushed < pa.size() ? pa[pushed] : 0.0);
  run_.point_axial_force.push_back(std::move(pa));
  run_.active_points.push_back(static_cast<int>(state_.active.size()));
  run_.solves.push_back(solves);
}

// The step's field: vertex displacements (every step with keep_step_fields, else the last), the largest
// displacement so far and the largest strain. `s` null: no solution (zero field), or, with `skipped`, a
// solution whose field the step did not form (SimulationOptions::step_fields): max_strain NaN.
template <int dim>
void NeedleInsertion<dim>::record_field(const fem::Solution<dim>* s, bool skipped) {
  if (skipped) {
    run_.max_strain.push_back(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  std::vector<Vec> vd;
  if (s) {
    vd.reserve(s->vertex_displacement.size());
    for (const auto& u : s->vertex_displacement) {
      vd.push_back(ctx_.tf.vector_to_world(u));
      run_.max_displacement = std::max(run_.max_displacement, u.norm());
    }
  } else {
    vd.assign(ctx_.model->vertices().size(), Vec::Zero());
  }
  if (ctx_.opt.keep_step_fields || run_.vertex_displacement.empty())
    run_.vertex_displacement.push_back(std::move(vd));
  else
    run_.vertex_displacement.back() = std::move(vd);
  run_.max_strain.push_back(s ? largest_principal_strain<dim>(s->cell_strain) : 0.0);
}

template <int dim>
void NeedleInsertion<dim>::output_step(int k, const fem::Solution<dim>* solution) {
  const std::string file = "steps/" + step_file(k, ctx_.opt.mpi_ranks);
  write_step_vtu<dim>(ctx_, prefix_ + file, solution);
  pvd_.emplace_back(run_.depth.back(), file);
}

template class NeedleInsertion<2>;
template class NeedleInsertion<3>;

}  // namespace vim::pipeline

// One needle inserted step by step (needle_insertion.hpp).
#include "simulation/needle_insertion.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <vim/fem/material.hpp>
#include <vim/pipeline/scenario/scenario_regions.hpp>

#include "simulation/largest_strain.hpp"
#include "simulation/near_field_strain.hpp"
#include "simulation/needle_options.hpp"
#include "simulation/simulation_output.hpp"

namespace vim::pipeline {

template <int dim>
NeedleInsertion<dim>::NeedleInsertion(SimulationContext<dim> &context, const NeedleSpec &spec,
                                      std::string prefix, bool snap_to_vertices)
    : ctx_(context),
      spec_(spec),
      needle_(needle_options<dim>(spec, context.tf, context.opt.max_active_set_iterations)),
      prefix_(std::move(prefix)) {
  axis_world_ = spec_vector<dim>(spec.direction).normalized();
  entry_world_ = spec_vector<dim>(spec.entry);
  axis_ = needle_.path.axis;
  std::vector<needle::ShaftPoint<dim>> shaft = make_coupling(snap_to_vertices);
  if (shaft.empty())
    throw ScenarioError(ctx_.sc.where(spec.line) + "needle '" + spec.name +
                        "': no point of its path lies in the free part of the "
                        "mesh (is it inside a fixed region?)");
  run_.name = spec.name;
  run_.axis = axis_world_;
  run_.entry = entry_world_;
  for (const auto &p : shaft) {
    run_.point_s.push_back(p.s);
    run_.point_length.push_back(p.length);
  }
  const std::size_t np = shaft.size();
  if (!spec.tissues.empty()) {  // each point's tissue (shaft stations, then tip disks), then its values
    std::vector<Vec> positions;
    for (const auto &p : shaft) positions.push_back(p.position);
    for (const auto &p : tip_rows_) positions.push_back(p.position);
    const auto lookup = tissue_lookup<dim>(
        spec,
        [this](const RegionSpec &r) {
          return scenario_region<dim>(r, ctx_.box_min, ctx_.box_max, ctx_.tf, ctx_.label_image.get());
        },
        [this](const Vec &x) {
          const long cell = ctx_.locator().locate(x);
          return cell >= 0 ? ctx_.E[static_cast<std::size_t>(cell)] : -1.0;
        });
    std::vector<int> tissue = point_tissues<dim>(lookup, positions);
    set_point_values(spec, tissue, needle_.friction);
    if (spec.model == NeedleSpec::Model::kinematic)
      set_path_values<dim>(spec, lookup, needle_.path, std::min(pitch_, needle_.path.depth / 16) / 16,
                           needle_.friction);
    tissue.resize(np);
    run_.point_tissue = std::move(tissue);
  }
  stepping_.emplace(needle_, std::move(shaft), std::move(tip_rows_));
  make_tissue(spec);
  if constexpr (dim == 3)
    if (spec.flexible && elastic_) {  // the scenario refuses a flexible needle on neo-Hookean tissue
      const FlexibleSpec &f = *spec.flexible;
      const needle::FlexibleNeedle tube{f.youngs_modulus, spec.diameter, f.inner_diameter, f.free_length};
      flexible_ = std::make_unique<needle::FlexibleTissue>(*elastic_, *deflected_, stepping_->state(),
                                                           stepping_->shaft(), axis_, tube, pitch_,
                                                           stepping_->n_points(), pitch_);
    }
  for (const auto &t : ctx_.sc.targets) targets_.push_back(ctx_.tf.to_frame(spec_vector<dim>(t.position)));
  for (double depth : spec.seeds) {
    typename NeedleRun<dim>::Seed seed;
    seed.depth = depth;
    seed.planned = entry_world_ + depth * axis_world_;
    seed_points_.push_back(needle_.path.entry + depth * axis_);
    run_.seeds.push_back(seed);
  }
  seed_displacement_.assign(seed_points_.size(), Vec::Zero());
  for (const auto &r : ctx_.released) earlier_points_.push_back(r.planned_frame);
  earlier_displacement_.assign(earlier_points_.size(), Vec::Zero());
  for (std::size_t i = 0; i < ctx_.sc.needles.size(); ++i)
    if (ctx_.sc.needles[i].name == spec.name) number_ = static_cast<int>(i) + 1;
  total_steps_ = needle_.steps + (spec.withdrawn_later() ? 0 : spec.withdraw_steps);
  if constexpr (dim == 3)
    band_check_ = check_bands(needle_.path.entry, axis_, coupling_radius_, run_.point_s, run_.point_length,
                              targets_, [this](const Vec &x) {
                                const long cell = ctx_.locator().locate(x);
                                return cell >= 0 ? ctx_.E[static_cast<std::size_t>(cell)] : -1.0;
                              });
  if (dim == 3)
    for (double s : run_.point_s) {  // the cell at the station's centre on the path
      const long cell = ctx_.locator().locate(needle_.path.entry + s * axis_);
      station_shear_.push_back(
          cell >= 0 ? fem::shear_modulus(ctx_.E[static_cast<std::size_t>(cell)], ctx_.sc.poisson_ratio)
                    : 0.0);
    }
  // External loads (a prescribed displacement, a pressure, a traction, a moved probe) and the needles left in
  // act from the start: before the tip reaches the first shaft point (step 0 included) the tissue deforms
  // under them alone, not rest.
  loaded_ = loaded();
  write_ = writes_steps(ctx_.opt) && ctx_.sc.output_every > 0;
}

template <int dim>
bool NeedleInsertion<dim>::loaded() const {
  return (elastic_ && elastic_->holds()) || (ctx_.probe && ctx_.probe->moved()) ||
         std::any_of(
             ctx_.sc.boundary_conditions.begin(), ctx_.sc.boundary_conditions.end(),
             [](const BoundaryConditionSpec &bc) { return bc.type != BoundaryConditionSpec::Type::fixed; });
}

// The tissue behind the rows: the linear model (holding the needles left in), or the neo-Hookean one
// (the scenario refuses needles left in with it).
template <int dim>
void NeedleInsertion<dim>::make_tissue(const NeedleSpec &spec) {
  if (ctx_.sc.material_model == Scenario::MaterialModel::neo_hookean) {
    auto tissue = std::make_unique<needle::NeoHookeanTissue<dim>>(*ctx_.model, *coupling_, stepping_->state(),
                                                                  stepping_->n_points());
    neo_hookean_ = tissue.get();
    tissue_ = std::move(tissue);
  } else {
    auto tissue = std::make_unique<needle::ElasticTissue<dim>>(*ctx_.model, *coupling_, stepping_->state(),
                                                               stepping_->n_points(), pitch_, ctx_.solver,
                                                               ctx_.opt.monolithic);
    tissue->hold(ctx_.staying);
    elastic_ = tissue.get();
    tissue_ = std::move(tissue);
  }
}

// 3D: band stations, uniform along the path (needle.sample_spacing, else the
// element size h near the path: the mesh resolves the field along the shaft on
// that scale), coupling radius needle.coupling_radius or the default rule from
// the element size near the path. 2D: points on the axis (sample_shaft; a
// plane-strain needle is a blade, and a line converges in 2D).
template <int dim>
std::vector<needle::ShaftPoint<dim>> NeedleInsertion<dim>::make_coupling(bool snap_to_vertices) {
  const needle::NeedlePath<dim> &path = needle_.path;
  std::vector<needle::ShaftPoint<dim>> shaft;
  axis_ = path.axis;
  if constexpr (dim == 3) {
    const double h = needle::path_element_size(ctx_.locator(), path.entry, path.axis, path.depth);
    const auto with_spacing = [&](needle::BandCoupling::Geometry geometry) {
      geometry.spacing = needle_.sample_spacing > 0.0 ? needle_.sample_spacing : h;
      return geometry;
    };
    needle::BandCoupling::Geometry g;
    g.entry = path.entry;
    g.axis = path.axis;
    g.to_world = ctx_.tf.direction;
    g.depth = path.depth;
    g.radius = 0.5 * needle_.diameter;
    g.coupling_radius = needle_.coupling_radius;
    g.element_size = h;
    g.degree = ctx_.degree;
    // The tip bearing when the tip cuts: disks every half element or step, whichever is shorter.
    const bool tissue_cuts = std::any_of(spec_.tissues.begin(), spec_.tissues.end(), [](const TissueSpec &t) {
      return t.cutting_force.value_or(0.0) > 0.0;
    });
    if ((needle_.friction.cutting_force > 0.0 || tissue_cuts) && needle_.friction.law != "force")
      g.tip_spacing = std::min(0.5 * h, path.depth / static_cast<double>(needle_.steps));
    auto band = std::make_unique<needle::BandCoupling>(
        with_spacing(g), ctx_.locator(), ctx_.E, ctx_.sc.poisson_ratio, ctx_.blocked, ctx_.held_regions);
    // A mesh so coarse that no band of the default size fits in it (every
    // sample outside): halve h.
    for (int k = 0; k < 8 && band->stations().empty() && needle_.coupling_radius <= 0.0; ++k) {
      g.element_size *= 0.5;
      band = std::make_unique<needle::BandCoupling>(with_spacing(g), ctx_.locator(), ctx_.E,
                                                    ctx_.sc.poisson_ratio, ctx_.blocked, ctx_.held_regions);
    }
    shaft = band->stations();
    tip_rows_ = band->tip_rows();
    pitch_ = shaft.empty() ? with_spacing(g).spacing : shaft.front().length;
    coupling_radius_ = band->coupling_radius();
    if (spec_.flexible) {
      auto deflected = std::make_unique<needle::DeflectedCoupling>(std::move(band));
      deflected_ = deflected.get();
      coupling_ = std::move(deflected);
    } else {
      coupling_ = std::move(band);
    }
  } else {
    pitch_ = needle_.sample_spacing > 0.0 ? needle_.sample_spacing : 0.5 * ctx_.locator().mean_edge_length();
    shaft = needle::sample_shaft<dim>(ctx_.locator(), path.entry, axis_, path.depth, pitch_, ctx_.blocked,
                                      snap_to_vertices);
    std::vector<Vec> positions;
    for (const auto &p : shaft) positions.push_back(p.position);
    coupling_ = std::make_unique<needle::LineCoupling<dim>>(std::move(positions), axis_, ctx_.point_axes);
  }
  return shaft;
}

template <int dim>
void NeedleInsertion<dim>::precompute() {
  if (!ctx_.opt.monolithic || neo_hookean_) {  // every shaft row's column K⁻¹cᵀ in one batch: no
                                               // step does a sparse solve (neo-Hookean: the rows)
    const auto t = Clock::now();
    tissue_->precompute(probe_points());
    run_.precompute_seconds += seconds_since(t);
  }
}

template <int dim>
NeedleOutcome<dim> NeedleInsertion<dim>::run() {
  const auto t_run = Clock::now();
  precompute();
  rest();
  record_newton(0);
  if (stepping_->law().has_active_set())
    run_.active_set_sweeps.assign(static_cast<std::size_t>(total_steps_) + 1, 0);
  for (std::size_t i = 0; i < run_.seeds.size(); ++i) run_.seeds[i].rest_displacement = seed_displacement_[i];
  const auto t_steps = Clock::now();
  take_steps(1);
  run_.stepping_seconds = seconds_since(t_steps);
  if (spec_.stay) leave_in();
  return finish(seconds_since(t_run));
}

template <int dim>
void NeedleInsertion<dim>::take_steps(int first) {
  Progress progress("needle " + spec_.name, total_steps_);
  for (int k = first; k <= total_steps_; ++k) {
    try {
      if (k <= needle_.steps)
        advance_one_step(k);
      else
        withdraw_one_step(k);
    } catch (const fem::NewtonFailure &e) {
      throw ScenarioError(ctx_.sc.where(ctx_.sc.material_model_line) + "material.model = 'neo-hookean': " +
                          (spec_.name.empty() ? std::string("the needle") : "needle '" + spec_.name + "'") +
                          ", step " + std::to_string(k) + ": " + e.what());
    }
    record_newton(k);
    if (ctx_.opt.progress) {
      std::ostringstream msg;
      msg << "step " << k << "/" << total_steps_ << ", depth " << run_.depth.back() << " "
          << ctx_.sc.length_unit << ", axial force " << run_.axial_force.back() << ", "
          << stepping_->state().active.size() << " shaft points";
      progress.report(k, msg.str());
    }
  }
}

template <int dim>
NeedleOutcome<dim> NeedleInsertion<dim>::finish(double run_seconds) {
  run_.solve_seconds = tissue_->solve_seconds();
  run_.steps_per_second = run_seconds > 0.0 ? total_steps_ / run_seconds : 0.0;
  for (std::size_t i = 0; i < run_.seeds.size(); ++i) {  // later runs carry this needle's seeds
    const auto &seed = run_.seeds[i];
    if (seed.release_step >= 0)
      ctx_.released.push_back(
          {seed_points_[i], seed.planned, seed.planned - seed.release_displacement, number_});
  }
  if (ctx_.opt.output_file) {
    if (write_) write_pvd(ctx_.opt.output_file(prefix_ + "simulation.pvd"), pvd_);
    if (write_ && ctx_.sc.procedure) write_pvd(ctx_.opt.output_file(prefix_ + "seeds.pvd"), seeds_pvd_);
    write_needle_csv<dim>(ctx_.opt.output_file(prefix_ + "needle.csv"), run_, ctx_.sc);
  }
  nlohmann::json report = needle_report<dim>(spec_, run_, stepping_->law(), pitch_, prefix_, run_seconds,
                                             tissue_->solves(), ctx_.opt.monolithic, ctx_.sc);
  std::vector<std::string> warnings;
  report["material_model"] = neo_hookean_ ? "neo-hookean" : "linear";
  report["energy"] = {{"needle_work", run_.needle_work.back()},
                      {"dissipated_work", run_.dissipated_work.back()},
                      {"join_work", run_.join_work.back()},
                      {"stored_energy_change",
                       run_.needle_work.back() - run_.dissipated_work.back() - run_.join_work.back()}};
  if (neo_hookean_) report["newton"] = {{"per_step", std::move(newton_steps_)}};
  if (dim == 3) {
    report["coupling_radius"] = coupling_radius_;
    nlohmann::json band = {{"radius", coupling_radius_},
                           {"modulus_change_threshold", kBandModulusChange},
                           {"targets_inside", nlohmann::json::array()},
                           {"modulus_changes", nlohmann::json::array()}};
    std::vector<std::string> names;
    for (std::size_t t = 0; t < ctx_.sc.targets.size(); ++t) {
      names.push_back(ctx_.sc.targets[t].name);
      if (band_check_.target_inside[t]) band["targets_inside"].push_back(names.back());
    }
    for (const auto &c : band_check_.modulus_changes)
      band["modulus_changes"].push_back({{"from", c.from}, {"to", c.to}, {"relative_change", c.change}});
    report["band"] = std::move(band);
    const std::string who = spec_.name.empty() ? std::string("the needle") : "needle '" + spec_.name + "'";
    const std::string w = band_warning(ctx_.sc.where(spec_.line), who, coupling_radius_, names, band_check_);
    if (!w.empty()) warnings.push_back(w);
  }
  return {std::move(run_), std::move(report), std::move(warnings)};
}

// Step 0: rest, or the external loads alone; their displacement across the axis
// at the shaft points is kept by the coupling.
template <int dim>
void NeedleInsertion<dim>::rest() {
  const fem::Solution<dim> *solution = loaded_ ? &tissue_->solution() : nullptr;
  if (loaded_) {
    tissue_->solve(stepping_->state().axial);
    tissue_->form_field();
    std::vector<std::size_t> all(stepping_->shaft().size());
    for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
    coupling_->keep_offsets(coupling_->displacements(all, *ctx_.model));
  }
  have_solution_ = loaded_;
  record(0.0, solution, loaded_ ? 1 : 0);
  record_field(solution, false);
  run_.step_seconds.push_back(0.0);
  if (write_) output_step(0, solution);
}

template <int dim>
void NeedleInsertion<dim>::advance_one_step(int k) {
  const double d = stepping_->depth(k);
  const double d_prev = run_.depth.back();
  const int solves_before = tissue_->solves();
  const auto t_step = Clock::now();
  stepping_->pick_up(d, d - d_prev, [this](std::size_t j) { return axial_displacement(j); });
  solve_state(k, d, solves_before, true);
  finish_step(k, t_step);
}

// The stepping's state after a pick-up or a withdrawal: the law's solve with the needle on the tissue
// (`bending`: the flexible needle's beam bent to depth d first), or without a shaft point on the needle
// (the tip has not reached the first one, or all have left it) the tissue at rest or under its loads.
template <int dim>
void NeedleInsertion<dim>::solve_state(int k, double d, int solves_before, bool bending) {
  const needle::ShaftState &state = stepping_->state();
  fem::Solution<dim> &solution = tissue_->solution();
  if (state.active.empty()) {
    if (loaded_)
      tissue_->solve(state.axial);
    else
      tissue_->clear();
    record(d, loaded_ ? &solution : nullptr, tissue_->solves() - solves_before);
    return;
  }
  const bool flexible = bending && flexible_;
  if (flexible) bend(d);
  const needle::FrictionStep step = flexible ? stepping_->solve(*flexible_) : stepping_->solve(*tissue_);
  rounds_ = step.rounds;
  if (neo_hookean_ && !step.settled)
    throw ScenarioError(ctx_.sc.where(ctx_.sc.material_model_line) + "material.model = 'neo-hookean': " +
                        (spec_.name.empty() ? std::string("the needle") : "needle '" + spec_.name + "'") +
                        ", step " + std::to_string(k) +
                        ": the friction active set and the Newton solve did not " + "settle in " +
                        std::to_string(needle::kMaxNonlinearRounds) + " rounds of " +
                        std::to_string(ctx_.max_sweeps()) + " sweeps (try more steps)");
  if (stepping_->law().has_active_set()) {
    run_.active_set_sweeps[static_cast<std::size_t>(k)] = step.sweeps;
    if (!step.settled) run_.unsettled_steps.push_back(k);
  }
  record(d, &solution, tissue_->solves() - solves_before);
}

// The step's field, time and step file.
template <int dim>
void NeedleInsertion<dim>::finish_step(int k, const std::chrono::steady_clock::time_point &t_step) {
  const needle::ShaftState &state = stepping_->state();
  fem::Solution<dim> &solution = tissue_->solution();
  have_solution_ = !state.active.empty() || loaded_;
  run_.stats = solution.stats;
  const bool written = write_ && (k % ctx_.sc.output_every == 0 || k == total_steps_);
  if (have_solution_ && (ctx_.opt.step_fields || written || k == total_steps_)) {
    tissue_->form_field();
    record_field(&solution, false);
  } else {
    record_field(nullptr, have_solution_);
  }
  run_.step_seconds.push_back(seconds_since(t_step));
  if (written) output_step(k, state.active.empty() && !loaded_ ? nullptr : &solution);
}

// The needle back out by depth / withdraw_steps: the stepping's withdrawal (friction reversing where the
// law lets the tissue slip), the law's solve, then the seeds whose planned depth the tip has reached.
template <int dim>
void NeedleInsertion<dim>::withdraw_one_step(int k) {
  const int i = k - needle_.steps;
  const double d = needle_.path.depth * (1.0 - static_cast<double>(i) / spec_.withdraw_steps);
  const double d_prev = run_.depth.back();
  const int solves_before = tissue_->solves();
  const auto t_step = Clock::now();
  stepping_->withdraw(d, d - d_prev);
  solve_state(k, d, solves_before, false);
  release_seeds(d, k);
  finish_step(k, t_step);
}

// The seeds the tip has reached on the way out (planned depth >= the tip's travel): each keeps the
// tissue's displacement at its planned position at this step (record()).
template <int dim>
void NeedleInsertion<dim>::release_seeds(double depth, int step) {
  const double eps = 1e-9 * needle_.path.depth;
  for (std::size_t i = 0; i < run_.seeds.size(); ++i) {
    auto &seed = run_.seeds[i];
    if (seed.release_step >= 0 || seed.depth < depth - eps) continue;
    seed.release_step = step;
    seed.release_displacement = seed_displacement_[i];
  }
}

// Neo-Hookean: step k's Newton solves (report.json needle "newton".per_step): per solve its
// continuation steps, each with its fraction of the way and the residual norms per Newton iteration.
template <int dim>
void NeedleInsertion<dim>::record_newton(int k) {
  if (!neo_hookean_) return;
  nlohmann::json solves = nlohmann::json::array();
  unsigned iterations = 0, halvings = 0;
  for (const needle::NewtonSolveRecord &r : neo_hookean_->take_records()) {
    nlohmann::json steps = nlohmann::json::array();
    for (const fem::LoadStepRecord &s : r.steps) {
      iterations += static_cast<unsigned>(s.update_norm.size());
      steps.push_back({{"fraction", s.load_factor},
                       {"residual_norm", s.residual_norm},
                       {"update_norm", s.update_norm},
                       {"line_search", s.line_search}});
    }
    halvings += r.halvings;
    solves.push_back({{"steps", std::move(steps)}, {"halvings", r.halvings}});
  }
  newton_steps_.push_back({{"step", k},
                           {"solves", solves.size()},
                           {"iterations", iterations},
                           {"halvings", halvings},
                           {"rounds", rounds_},
                           {"newton", std::move(solves)}});
  rounds_ = 0;
}

template <int dim>
void NeedleInsertion<dim>::account_energy(double travel, const fem::Solution<dim> *s) {
  const std::size_t n = stepping_->n_points();
  std::vector<double> f(n, 0.0), u(n, 0.0);
  std::vector<bool> on(n, false);
  std::vector<double> carried(n, 0.0);  // the shaft length each point carries (grows as it joins)
  const needle::ShaftState &state = stepping_->state();
  for (std::size_t j = 0; j < n && j < state.carried.size(); ++j) carried[j] = state.carried[j];
  if (s) {
    f = coupling_->axial_forces(stepping_->state().active, *s);
    f.resize(n, 0.0);
    for (std::size_t j = 0; j < n; ++j) u[j] = tissue_->held_axial(j, axis_);
    for (std::size_t j : stepping_->state().active) on[j] = true, u[j] = stepping_->state().axial[j];
  }
  double energy = 0.0;  // Clapeyron: ½ Σ f_j ū_j
  for (std::size_t j = 0; j < n; ++j) energy += 0.5 * f[j] * u[j];
  run_.row_energy.push_back(energy);
  double work = 0.0, dissipated = 0.0, joins = 0.0;
  for (std::size_t j = 0; j < point_force_.size(); ++j) {
    const double mean = 0.5 * (f[j] + point_force_[j]);
    work += mean * travel;
    // On the needle at both ends of the step, carrying the same length: friction × slip; joining or leaving
    // it (or a part of its segment): the tissue's jump to or from the needle.
    const bool kept = on[j] && point_on_[j] && carried[j] == point_carried_[j];
    (kept ? dissipated : joins) += mean * (travel - (u[j] - point_axial_[j]));
  }
  const auto add = [](std::vector<double> &sum, double x) {
    sum.push_back((sum.empty() ? 0.0 : sum.back()) + x);
  };
  add(run_.needle_work, work);
  add(run_.dissipated_work, dissipated);
  add(run_.join_work, joins);
  point_force_ = std::move(f);
  point_on_ = std::move(on);
  point_carried_ = std::move(carried);
  point_axial_ = std::move(u);
}

template <int dim>
double NeedleInsertion<dim>::axial_displacement(std::size_t j) const {
  return have_solution_ ? tissue_->held_axial(j, axis_) : 0.0;
}

// Needle force F = −Σ point forces (the force the tissue exerts on the needle),
// world axes; axial = −F·a (insertion resistance, > 0 when the tissue resists)
// and lateral = |F − (F·a)a|.
template <int dim>
void NeedleInsertion<dim>::record(double depth, const fem::Solution<dim> *s, int solves) {
  account_energy(run_.depth.empty() ? 0.0 : depth - run_.depth.back(), s);
  run_.depth.push_back(depth);
  run_.tip.push_back(entry_world_ + depth * axis_world_);
  if (flexible_) record_flexible(depth);
  Vec f = Vec::Zero();
  if (s)
    for (const auto &pf : s->point_force) f -= pf;
  f = ctx_.tf.vector_to_world(f);
  run_.force.push_back(f);
  const double ax = f.dot(axis_world_);
  run_.axial_force.push_back(0.0 - ax);  // +0 at rest
  run_.lateral_force.push_back((f - ax * axis_world_).norm());
  std::vector<Vec> td(targets_.size(), Vec::Zero());
  std::fill(seed_displacement_.begin(), seed_displacement_.end(), Vec::Zero());
  std::fill(earlier_displacement_.begin(), earlier_displacement_.end(), Vec::Zero());
  const std::vector<Vec> probes = probe_points();
  if (s && !probes.empty()) {
    auto u =
        coupling_->tissue_displacements(probes, tissue_->probe_displacements(probes), stepping_->state(), *s);
    // The needles left in: their near fields too, with the forces their rows carry now.
    // (only the linear tissue holds them: a neo-Hookean run refuses them)
    static const std::vector<Vec> none;
    const std::vector<Vec> &held = elastic_ ? elastic_->held_forces() : none;
    std::size_t first = 0;
    for (const auto &staying : ctx_.staying_needles) {
      fem::Solution<dim> rows;
      rows.point_force.assign(held.begin() + static_cast<long>(first),
                              held.begin() + static_cast<long>(first + staying.rows));
      u = staying.coupling->tissue_displacements(probes, std::move(u), staying.state, rows);
      first += staying.rows;
    }
    const std::size_t own = td.size() + seed_points_.size();
    for (std::size_t t = 0; t < u.size(); ++t)
      (t < td.size() ? td[t]
       : t < own     ? seed_displacement_[t - td.size()]
                     : earlier_displacement_[t - own]) = ctx_.tf.vector_to_world(u[t]);
  }
  run_.target_displacement.push_back(td);
  const needle::ShaftState &state = stepping_->state();
  std::vector<double> pa(stepping_->shaft().size(), 0.0);
  if (s) pa = coupling_->axial_forces(state.active, *s);
  pa.resize(std::max(pa.size(), stepping_->n_points()), 0.0);
  // The axial force splits into the shaft's friction and the force on the
  // tissue the tip pushes (the cutting station; the force model: the tip point,
  // which carries tip_force).
  const std::size_t pushed = stepping_->tip_point();
  double friction = 0.0;
  for (std::size_t j : state.active)
    if (j != pushed) friction += pa[j];
  run_.friction_force.push_back(s ? friction : 0.0);
  run_.tip_force.push_back(s && pushed < pa.size() ? pa[pushed] : 0.0);
  const bool cutting = s && state.tip_cutting;
  if (cutting && !run_.tip_cutting.empty() && run_.tip_cutting.back() == 0)
    run_.punctures.push_back({depth, run_.axial_force[run_.axial_force.size() - 2], run_.axial_force.back()});
  run_.tip_cutting.push_back(cutting ? 1 : 0);
  record_near_field(depth, pa);
  pa.resize(stepping_->shaft().size());  // the shaft stations' (the tip rows' is tip_force)
  run_.point_axial_force.push_back(std::move(pa));
  run_.active_points.push_back(static_cast<int>(state.active.size()));
  run_.solves.push_back(solves);
}

// The flexible needle at needle depth d: the beam to its end, the bevel's load and, at the last insertion
// step, the holder's offset. The tissue pushes
// on the bevel's face, whose outward normal's lateral part is the bevel side (turned by the rotations
// the needle has reached): the lateral force on the needle is along −side, cot(angle) × the tip's axial
// force (docs/needle-model.md, the bevel).
template <int dim>
void NeedleInsertion<dim>::bend(double d) {
  if constexpr (dim == 3) {
    Vec direction = Vec::Zero();
    double ratio = 0.0;
    if (spec_.bevel) {
      double turn = 0.0;
      for (const RotationSpec &r : spec_.rotations)
        if (r.depth <= d + 1e-9 * needle_.path.depth) turn += r.angle;
      const Vec side =
          Eigen::AngleAxisd(turn * M_PI / 180.0, axis_world_) * spec_vector<dim>(spec_.bevel->side);
      direction = -ctx_.tf.vector_to_frame(side);
      ratio = 1.0 / std::tan(spec_.bevel->angle * M_PI / 180.0);
    }
    // The holder's sideways move (needle.flexible.base_offset) at the last insertion step.
    const bool last = d >= needle_.path.depth * (1.0 - 1e-9);
    const Vec offset =
        last ? ctx_.tf.vector_to_frame(spec_vector<dim>(spec_.flexible->base_offset)) : Vec::Zero();
    flexible_->set_depth(d, direction, ratio, offset);
  } else {
    (void)d;
  }
}

// The flexible needle's tip, its deviation and angle, the base's loads and the shape (the beam's nodes)
// of the last solve; straight before the needle touches the tissue.
template <int dim>
void NeedleInsertion<dim>::record_flexible(double depth) {
  if constexpr (dim == 3) {
    const bool bent = !stepping_->state().active.empty() && flexible_->depth() == depth;
    const auto world = [this](const Vec &v) { return ctx_.tf.vector_to_world(v); };
    const Vec deviation = bent ? world(flexible_->deflection(depth)) : Vec::Zero();
    run_.tip.back() += deviation;
    run_.tip_deviation.push_back(deviation);
    run_.tip_angle.push_back(bent ? std::atan(flexible_->slope(depth).norm()) * 180.0 / M_PI : 0.0);
    run_.base_force.push_back(bent ? world(flexible_->base_force()) : Vec::Zero());
    run_.base_moment.push_back(bent ? world(flexible_->base_moment()) : Vec::Zero());
    std::vector<Vec> shape;
    if (bent)
      for (double s : flexible_->beam().nodes())
        shape.push_back(entry_world_ + s * axis_world_ + world(flexible_->deflection(s)));
    else
      for (double s : {-spec_.flexible->free_length, depth}) shape.push_back(entry_world_ + s * axis_world_);
    run_.shape.push_back(std::move(shape));
  } else {
    (void)depth;
  }
}

// The step's field: vertex displacements (every step with keep_step_fields,
// else the last), the largest displacement so far and the largest strain. `s`
// null: no solution (zero field), or, with `skipped`, a solution whose field
// the step did not form (SimulationOptions::step_fields): max_strain NaN.
template <int dim>
void NeedleInsertion<dim>::record_field(const fem::Solution<dim> *s, bool skipped) {
  if (skipped) {
    run_.max_strain.push_back(std::numeric_limits<double>::quiet_NaN());
    run_.mesh_strain.push_back(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  std::vector<Vec> vd;
  if (s) {
    vd.reserve(s->vertex_displacement.size());
    for (const auto &u : s->vertex_displacement) {
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
  const double near = run_.near_field_strain.size() > run_.max_strain.size()
                          ? run_.near_field_strain[run_.max_strain.size()]
                          : 0.0;
  run_.mesh_strain.push_back(s ? largest_principal_strain<dim>(s->cell_strain) : 0.0);
  run_.max_strain.push_back(std::max(near, run_.mesh_strain.back()));
}

// 3D: the strain of the shaft's near field (near_field_strain.hpp) at this step, and the targets
// within the distance of the inserted shaft where it exceeds the small-strain limit.
template <int dim>
void NeedleInsertion<dim>::record_near_field(double depth, const std::vector<double> &axial_force) {
  if (dim != 3) return;
  const needle::ShaftState &state = stepping_->state();
  const NearFieldStrain field =
      shaft_near_field(state.active, axial_force, state.carried, station_shear_, 0.5 * needle_.diameter);
  run_.near_field_strain.push_back(field.surface_strain);
  run_.small_strain_radius.push_back(field.small_strain_radius);
  std::vector<int> inside(targets_.size(), 0);
  for (std::size_t t = 0; t < targets_.size(); ++t) {
    const Vec x = targets_[t] - needle_.path.entry;
    const double s = x.dot(axis_);
    inside[t] = s >= 0.0 && s <= depth && (x - s * axis_).norm() < field.small_strain_radius ? 1 : 0;
  }
  run_.target_in_near_field.push_back(std::move(inside));
}

template <int dim>
void NeedleInsertion<dim>::output_step(int k, const fem::Solution<dim> *solution) {
  const std::string file = "steps/" + step_file(k, ctx_.opt.mpi_ranks);
  write_step_vtu<dim>(ctx_, prefix_ + file, solution);
  pvd_.push_back({run_.depth.back(), file, 0});
  if (ctx_.opt.output_file) {  // the needle beside the tissue: its shape, or the rigid needle's straight line
    const std::string needle = "steps/" + needle_step_file(k);
    const std::vector<Vec> straight{entry_world_, run_.tip.back()};
    write_needle_vtp<dim>(ctx_.opt.output_file(prefix_ + needle), flexible_ ? run_.shape.back() : straight,
                          entry_world_, axis_world_);
    pvd_.push_back({run_.depth.back(), needle, 1});
  }
  if (ctx_.sc.procedure && ctx_.opt.output_file) output_seeds(k);
}

template <int dim>
std::vector<typename NeedleInsertion<dim>::Vec> NeedleInsertion<dim>::probe_points() const {
  std::vector<Vec> probes = targets_;
  probes.insert(probes.end(), seed_points_.begin(), seed_points_.end());
  probes.insert(probes.end(), earlier_points_.begin(), earlier_points_.end());
  return probes;
}

// The seeds released so far (by the needles before, then this one's) where the tissue has moved them at
// step k: X + u_k(P), X the material point each was released at (the seed rule, docs/procedure.md).
template <int dim>
void NeedleInsertion<dim>::output_seeds(int k) {
  std::vector<Vec> position, planned;
  std::vector<int> needle;
  for (std::size_t i = 0; i < ctx_.released.size(); ++i) {
    const auto &r = ctx_.released[i];
    position.push_back(r.material + earlier_displacement_[i]);
    planned.push_back(r.planned);
    needle.push_back(r.needle);
  }
  for (std::size_t i = 0; i < run_.seeds.size(); ++i) {
    const auto &seed = run_.seeds[i];
    if (seed.release_step < 0) continue;
    position.push_back(seed.planned - seed.release_displacement + seed_displacement_[i]);
    planned.push_back(seed.planned);
    needle.push_back(number_);
  }
  char name[32];
  std::snprintf(name, sizeof name, "steps/seeds_%04d.vtu", k);
  write_seed_points<dim>(ctx_.opt.output_file(prefix_ + name), position, planned, needle);
  seeds_pvd_.push_back({run_.depth.back(), name, 0});
}

template class NeedleInsertion<2>;
template class NeedleInsertion<3>;

}  // namespace vim::pipeline

// Private to the simulation sources: one needle of the scenario pushed into the
// tissue step by step, shaped like deal.II's step-18 — set-up (the constructor:
// the coupling from the model, the needle library's stepping and tissue),
// advance_one_step (the stepping's pick-up and the law's solve), record
// (forces, target displacements), output (simulation_output.hpp). The physics
// is the needle library's (vim/needle/): the stepping (needle::Insertion) talks
// to the tissue only through needle::TissueResponse, here the condensed elastic
// model (needle::ElasticTissue) or the neo-Hookean model solved by Newton per step
// (needle::NeoHookeanTissue), and to the contact only through a
// needle::FrictionLaw and a needle::NeedleCoupling. 3D: band stations
// (BandCoupling); 2D: points on the axis (LineCoupling).
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <vim/needle/band_coupling.hpp>
#include <vim/needle/elastic_tissue.hpp>
#include <vim/needle/flexible/flexible_tissue.hpp>
#include <vim/needle/insertion.hpp>
#include <vim/needle/line_coupling.hpp>
#include <vim/needle/needle_options.hpp>
#include <vim/needle/neo_hookean_tissue.hpp>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation/band_check.hpp"
#include "simulation/simulation_context.hpp"
#include "simulation/simulation_output.hpp"

namespace vim::pipeline {

template <int dim>
class NeedleInsertion {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  // Samples the shaft (snap_to_vertices: see needle::sample_shaft) and chooses
  // the coupling and the law. Throws ScenarioError when no shaft point lies in
  // the free part of the mesh.
  NeedleInsertion(SimulationContext<dim> &context, const NeedleSpec &spec, std::string prefix,
                  bool snap_to_vertices);
  // Rest (or the external loads alone), then every step; writes the step files,
  // the .pvd and needle.csv when the options name an output folder; returns
  // the run with the needle's report entry.
  NeedleOutcome<dim> run();
  // A needle left in (stay: true) whose withdrawal a later action asks for (NeedleSpec::withdrawn_later),
  // after run() and the actions between: its rows are no longer held for the others, the tissue is set up
  // again with the needles still left in and the loads as they are now, and the needle comes out in
  // spec.withdraw_steps steps from its last state. `runs[index]` is its run so far (taken and returned
  // in the outcome, the steps appended); the seeds the other runs released end where it leaves the tissue.
  NeedleOutcome<dim> withdraw_later(std::vector<NeedleRun<dim>> &runs, std::size_t index);

 private:
  void precompute();
  void take_steps(int first);  // steps first…total_steps_: in, then out
  void leave_in();             // its rows held for the later actions (ctx_.staying)
  void release_hold();         // no longer: its rows leave ctx_.staying
  bool loaded() const;         // external loads or needles left in deform the tissue from step 0
  NeedleOutcome<dim> finish(double run_seconds);  // files, report, warnings
  void rest();
  void advance_one_step(int k);
  void solve_state(int k, double d, int solves_before, bool bending);
  // Withdrawal step k (of spec.withdraw_steps; step steps + k of the run), and the seeds the tip passes.
  void withdraw_one_step(int k);
  void release_seeds(double depth, int step);
  void finish_step(int k, const std::chrono::steady_clock::time_point &t_step);
  double axial_displacement(std::size_t j) const;  // ū_j of the last solution (0 before any)
  std::vector<needle::ShaftPoint<dim>> make_coupling(bool snap_to_vertices);
  void make_tissue(const NeedleSpec &spec);  // tissue_ (and elastic_ or neo_hookean_) on the coupling
  void record(double depth, const fem::Solution<dim> *solution, int solves);
  // The step's needle work and dissipated work (NeedleRun::needle_work) from the points' axial forces and
  // the tissue's axial displacement at their rows, now and at the last step (point_force_, point_axial_).
  void account_energy(double travel, const fem::Solution<dim> *solution);
  std::vector<double> point_force_, point_axial_;
  std::vector<bool> point_on_;         // on the needle at the last step
  std::vector<double> point_carried_;  // the shaft length each point carried then
  void record_flexible(double depth);
  void bend(double depth);  // the flexible needle's beam and bevel at this step
  void record_field(const fem::Solution<dim> *solution, bool skipped);
  void record_near_field(double depth, const std::vector<double> &axial_force);
  void output_step(int k, const fem::Solution<dim> *solution);
  void output_seeds(int k);               // a procedure's seeds released so far, at step k
  std::vector<Vec> probe_points() const;  // targets, this needle's seeds, the earlier seeds (frame)

  SimulationContext<dim> &ctx_;
  const NeedleSpec spec_;              // a copy: a needle withdrawn later outlives the caller's spec
  needle::NeedleOptions<dim> needle_;  // the needle as the needle library takes it (frame)
  std::string prefix_;
  Vec axis_world_, entry_world_, axis_;  // axis_: frame
  double pitch_ = 0.0;                   // spacing of the shaft points (3D: the stations' band length)
  double coupling_radius_ = 0.0;         // 3D: R of the bands
  std::shared_ptr<needle::NeedleCoupling<dim>> coupling_;  // shared: kept by a needle that stays
  std::vector<needle::ShaftPoint<dim>> tip_rows_;          // 3D with a cutting force: the tip bearing's disks
  std::optional<needle::Insertion<dim>> stepping_;
  // The tissue: the linear model condensed (elastic_) or, with material.model neo-hookean, the
  // finite-strain model solved by Newton per step (neo_hookean_).
  std::unique_ptr<needle::ModelTissue<dim>> tissue_;
  needle::ElasticTissue<dim> *elastic_ = nullptr;
  needle::NeoHookeanTissue<dim> *neo_hookean_ = nullptr;
  nlohmann::json newton_steps_ = nlohmann::json::array();  // neo-Hookean: per step, its Newton solves
  int rounds_ = 0;  // the last solve's rounds of map and Newton solve (FrictionStep::rounds)
  void record_newton(int k);
  // 3D with needle.flexible: the beam between the stepping and the tissue, and its rows.
  needle::DeflectedCoupling *deflected_ = nullptr;
  std::unique_ptr<needle::FlexibleTissue> flexible_;
  std::vector<Vec> targets_;            // frame
  std::vector<Vec> seed_points_;        // frame: the seeds' planned positions (probed after the targets)
  std::vector<Vec> seed_displacement_;  // world: the tissue's displacement there at the last recorded step
  std::vector<Vec> earlier_points_;     // frame: the planned positions of the seeds released before this run
  std::vector<Vec> earlier_displacement_;  // world: the tissue's displacement there at the last recorded step
  int number_ = 0;                         // the needle's number in the scenario (1, 2, …)
  int total_steps_ = 0;                    // insertion and withdrawal steps
  std::vector<double> station_shear_;      // 3D: the shear modulus of the tissue at each shaft station
  BandCheck band_check_;                   // 3D: the targets and modulus changes inside the bands
  bool loaded_ = false;                    // external loads act from step 0
  bool write_ = false;
  bool have_solution_ = false;

  NeedleRun<dim> run_;
  std::vector<PvdDataSet> pvd_, seeds_pvd_;
};

}  // namespace vim::pipeline

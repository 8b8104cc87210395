// Private to the simulation sources: one needle pushed into the tissue step by step, shaped like
// deal.II's step-18 — set-up (the constructor: shaft stations, coupling, law), advance_one_step (pick-up
// and the law's solve), record (forces, target displacements), output (simulation_output.hpp). The
// loop talks to the needle-tissue physics only through FrictionLaw and NeedleCoupling
// (needle_coupling.hpp). 3D: band stations (BandCoupling); 2D: points on the axis (LineCoupling).
//
// Each station stands for its band [b_j, e_j] of the path (3D: its segment; 2D: from its segment's
// start to the point). Positions are current ones, b_j + ū_j (ū_j the axial displacement the station's
// rows hold in the previous step's solution: tissue ahead of the tip is pushed before it is pierced),
// and the tip is the needle's cutting_distance δ behind its end (cut = depth − δ).
//  * A station joins the shaft when the tip has passed its band (e_j + ū_j < cut), at its current
//    displacement plus the needle's travel since (cut − e_j): no jump, so the force does not drop.
//  * With a cutting force F_c > 0 (kinematic model) the station whose band the tip has entered
//    (b_j + ū_j < cut) is the tissue the tip pushes (ShaftState::cutting): it joins the active set
//    (at cut − b_j) and moves with the needle until its load reaches F_c, then is held at F_c by the
//    law; it becomes a shaft station once the tip has passed its band. With F_c = 0 that tissue is
//    free (cut without resistance).
// Each station carries its segment of the shaft as far as the tip has passed (the last one everything
// up to the tip).
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <vim/fem/condensed_constraints.hpp>
#include <vim/fem/needle_band.hpp>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/simulation/needle_coupling.hpp>

#include "simulation/simulation_context.hpp"

namespace vim::pipeline {

template <int dim>
class NeedleInsertion final : public TissueResponse {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  // Samples the shaft (snap_to_vertices: see sample_shaft) and chooses the coupling and the law.
  // Throws ScenarioError when no shaft point lies in the free part of the mesh.
  NeedleInsertion(SimulationContext<dim>& context, const NeedleSpec& spec, std::string prefix,
                  bool snap_to_vertices);
  // Rest (or the external loads alone), then every step; writes the step files, the .pvd and
  // needle.csv when the options name an output folder, and fills the needle's report entry.
  NeedleRun<dim> run(nlohmann::json& report);

  std::vector<double> solve(const std::vector<double>& axial) override;
  const AxialMap& axial_map() override;

 private:
  void precompute();
  void rest();
  void advance_one_step(int k);
  void pick_up(double depth, double travel);
  double axial_displacement(std::size_t j) const;  // ū_j of the last solution (0 before any)
  void make_coupling(const NeedlePath<dim>& path, bool snap_to_vertices);
  void record(double depth, const fem::Solution<dim>* solution, int solves);
  void record_field(const fem::Solution<dim>* solution, bool skipped);
  void output_step(int k, const fem::Solution<dim>* solution);
  // The whole field of the last solve into solution_ (once per solve; the monolithic solve has it).
  void form_field();

  SimulationContext<dim>& ctx_;
  const NeedleSpec& spec_;
  std::string prefix_;
  Vec axis_world_, entry_world_, axis_;  // axis_: frame
  double pitch_ = 0.0;                   // spacing of the shaft points (3D: the stations' band length)
  double coupling_radius_ = 0.0;         // 3D: R of the bands
  std::vector<ShaftPoint<dim>> shaft_;
  std::vector<double> start_;  // arc length where each point's shaft segment (and band) starts
  std::vector<double> end_;    // arc length where its band ends: the tip has passed it there
  std::unique_ptr<NeedleCoupling<dim>> coupling_;
  std::unique_ptr<FrictionLaw> law_;
  std::vector<Vec> targets_;  // frame
  bool loaded_ = false;       // external loads act from step 0
  bool write_ = false;

  ShaftState state_;
  std::vector<bool> picked_;
  bool cuts_ = false;  // the kinematic model with a cutting force: the tip pushes a station
  bool have_solution_ = false;
  // The condensed rows of every shaft point and the targets (not with the monolithic reference): a
  // solve gives the point forces and the target displacements; the field only when form_field asks.
  std::unique_ptr<fem::CondensedConstraints<dim>> condensed_;
  std::vector<Vec> held_;  // the active rows' displacements of a solve
  fem::Solution<dim> solution_;
  bool field_ = false;  // solution_ holds the whole field of the last solve
  AxialMap map_;
  std::size_t map_size_ = 0;
  int solves_ = 0;
  double solve_seconds_ = 0.0;

  NeedleRun<dim> run_;
  std::vector<std::pair<double, std::string>> pvd_;
};

}  // namespace vim::pipeline

// Private to the simulation sources: one needle pushed into the tissue step by step, shaped like
// deal.II's step-18 — set-up (the constructor: shaft points, coupling, law), advance_one_step (pick-up
// and the law's solve), record (forces, target displacements), output (simulation_output.hpp). The
// loop talks to the needle-tissue physics only through FrictionLaw and NeedleCoupling
// (needle_coupling.hpp).
//
// Pick-up: the tip reaches a shaft point s_j when it reaches the point's current position s_j + u_j·a
// (u from the previous step: tissue ahead of the tip is pushed before it is pierced); with the needle's
// cutting_distance δ it must pass that position by δ, and the point joins δ behind the tip. The most
// recently picked-up point is the one the tip pushes; each point carries its segment of the shaft as far
// as the tip has passed (the pushed point everything up to the tip).
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <vim/pipeline/needle_coupling.hpp>
#include <vim/pipeline/progress.hpp>

#include "simulation_context.hpp"

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
  void record(double depth, const fem::Solution<dim>* solution, int solves);
  void output_step(int k, const fem::Solution<dim>* solution);

  SimulationContext<dim>& ctx_;
  const NeedleSpec& spec_;
  std::string prefix_;
  Vec axis_world_, entry_world_, axis_;  // axis_: frame
  double pitch_ = 0.0;
  std::vector<ShaftPoint<dim>> shaft_;
  std::vector<double> start_;  // arc length where each point's shaft segment starts
  std::unique_ptr<NeedleCoupling<dim>> coupling_;
  std::unique_ptr<FrictionLaw> law_;
  std::vector<Vec> targets_;  // frame
  bool loaded_ = false;       // external loads act from step 0
  bool write_ = false;

  ShaftState state_;
  std::vector<bool> picked_;
  bool have_solution_ = false;
  fem::Solution<dim> solution_;
  AxialMap map_;
  std::size_t map_size_ = 0;
  int solves_ = 0;
  double solve_seconds_ = 0.0;

  NeedleRun<dim> run_;
  std::vector<std::pair<double, std::string>> pvd_;
};

}  // namespace vim::pipeline

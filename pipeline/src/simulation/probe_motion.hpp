// Private to the simulation sources: a procedure's probe motion (docs/procedure.md, the probe). The probe
// is a rigid body the tissue is bonded to through an elastic foundation (a volume support of the model);
// moving it moves the foundation's base, b(x) = R(θ)(x − c) + c + t − x for the pose (t, θ) reached (c the
// axis centre at the start, R(θ) the rotation about the probe's axis), a change of the load alone: each
// step is one solve with the factorisation and the needles left in (their rows held as they were left).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>
#include <vim/pipeline/output/vtk_output.hpp>

#include "simulation/simulation_context.hpp"

namespace vim::pipeline {

// The probe's motions of a run, in the procedure's order between its needles.
template <int dim>
class ProbeMotions {
 public:
  explicit ProbeMotions(SimulationContext<dim>& ctx) : ctx_(ctx) {}
  // Each step of `motion`: the base moved to the step's pose, the solve, the probe's force and moment,
  // the targets and the released seeds, and the step files (probe/steps/step_NNNN.vtu, seeds_NNNN.vtu,
  // numbered over all probe steps): res.probe_steps grows, and the final positions of res.needles'
  // released seeds follow the tissue.
  void move(const ProbeMotionSpec& motion, SimulationResult<dim>& res);
  // probe.csv, probe/simulation.pvd and probe/seeds.pvd when the run writes files, and report.json's
  // simulation.probe: the foundation, the motions and per step the pose, force, moment.
  nlohmann::json finish(const std::vector<ProbeStep<dim>>& steps) const;

 private:
  using Vec = Eigen::Matrix<double, dim, 1>;
  void output_step(int k, const fem::Solution<dim>& solution, const std::vector<Vec>& seed_displacement);

  SimulationContext<dim>& ctx_;
  std::vector<PvdDataSet> pvd_, seeds_pvd_;
};

}  // namespace vim::pipeline

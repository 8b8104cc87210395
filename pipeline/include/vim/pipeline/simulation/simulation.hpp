// Needle-insertion simulation on the meshed model (docs/architecture.md): per-cell modulus (Eq. 15),
// boundary conditions from the scenario (world regions mapped to the image frame), and a rigid straight
// needle advanced in steps. Each step is one ElasticModel::solve with embedded-point constraints on
// the fast condensed path: before stepping, K is factorised and the column K⁻¹cᵀ of every shaft
// point's rows computed in one batch (ElasticModel::precompute), so a step does dense work only.
//
// Needle models (all in the reference configuration, small strain). In 3D the "shaft points" below are
// band stations of the needle of radius diameter/2 (needle::BandCoupling, vim/needle/band_coupling.hpp): the
// mean displacement of a band of a cylinder around the shaft, held through the analytic annulus compliance,
// joining as soon as the cut passes its band's start, at the mean stick value of its cut part, and carrying
// that part (vim/needle/insertion.hpp); with a cutting force the tip presses the tissue ahead of it as a
// flat punch (the tip bearing, vim/needle/tip_bearing.hpp) until its force reaches the cutting force, then
// cuts at that force (docs/needle-model.md §9). In 2D they are points on the axis line and the bullets
// below describe them.
//  * kinematic / stick: shaft points s_j = entry + s·a are sampled along the path (about one per cell
//    crossed). A point is picked up when the tip reaches its current position (s_j + u_j·a < d, with u
//    from the previous step: tissue ahead of the tip is pushed before it is pierced); from then on it
//    moves with the rigid needle: u_j = (d − s_j)·a, lateral displacement 0 (it stays on the shaft). The most
//    recently picked-up point is the one the tip pushes. Pure stick drags the shaft's tissue along
//    with the needle; it is the upper bound of tissue drag. With the needle's cutting_distance δ > 0
//    a point is picked up only once the tip has passed its current position by δ (s_j + u_j·a < d − δ)
//    and is then held δ behind the tip (u_j = (d − δ − s_j)·a): no point is picked up just behind the
//    tip at the end of a step only to be held back by the needle.
//  * kinematic / stick-slip: the same, but a point whose axial load exceeds max_shear_per_length × (the
//    shaft length it carries: its segment of the path as far as the tip has passed; the point the tip
//    pushes carries everything up to the tip, so the limits sum to max_shear_per_length × depth) slides:
//    its axial value is solved on the axial map of the active points (AxialMap, probed with one fast
//    solve per point) so that its load equals the limit; slip accumulates (u_j = d − s_j − slip_j).
//    Lateral displacement stays 0. Active set: a sliding point that would have to move ahead of the
//    needle to hold its limit sticks again.
//  * force: every passed shaft point carries the axial friction force friction_per_length × (carried length)
//  and
//    the most recently picked-up point also the tip force; lateral displacement 0 (the shaft holds the
//    tissue). Point loads are realised as point constraints whose axial values are solved for.
// Needle force: F = −Σ point_force (the force the tissue exerts on the needle), world axes; reported as
// axial = −F·a (insertion resistance, > 0 when the tissue resists) and lateral = |F − (F·a)a|. Forces
// are in modulus × length² (kPa·mm² = mN) in 3D and per unit thickness (mN/mm) in 2D (plane strain).
//
// Code: NeedleSimulation builds the model once (simulation.cpp); each needle runs in
// needle_insertion.cpp, with the needle library's stepping (needle::Insertion), which talks to the
// tissue only through needle::TissueResponse (here needle::ElasticTissue, the condensed linear model, or
// needle::NeoHookeanTissue with material.model neo-hookean) and to
// the contact through a needle::FrictionLaw and a needle::NeedleCoupling (vim/needle/); the needle is
// translated from the scenario in needle_options.cpp; the files and report entries are written by
// simulation_output.cpp.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/output/vtk_output.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// The automatic solver choice of a 3D scenario with a needle: the direct solver (CHOLMOD) up to this
// many DoFs (fem::SolverOptions::direct_limit), CG + AMG above.
inline constexpr unsigned kNeedleDirectLimit3D = 300000;

struct SimulationOptions {
  // Where to write: returns the absolute path for a file relative to the output folder (creating
  // parent folders), e.g. OutputDirectory::file. Empty: write nothing (tests, benchmarks).
  std::function<std::filesystem::path(const std::string& relative)> output_file;
  std::optional<unsigned> degree;  // overrides scenario mesh.degree (the CLI's --degree)
  bool monolithic = false;         // solve each step with solve_monolithic (reference for the fast path)
  bool keep_step_fields = false;   // keep every step's vertex displacement in the result (tests)
  bool progress = true;            // a progress line per step on stderr
  // Every needle step forms the whole field (vertex displacements, strains: max_strain and
  // max_displacement per step). false: only the written steps and the last do; the others give the
  // forces and the targets' displacements alone (their max_strain is NaN) — the real-time rate.
  bool step_fields = true;
  // Stick-slip: active-set sweeps per step (each one condensed solve). A step whose set still changes
  // after this many keeps the last iterate and is listed in NeedleRun::unsettled_steps and the warnings.
  int max_active_set_iterations = 100;
  // The scenario (a static load case or its needles) is also solved by the other material model (linear
  // and neo-Hookean), and report.json's simulation.compare_linear holds the relative differences
  // (static_load.hpp, needle_compare_linear.hpp).
  bool compare_linear = false;
  // The model's grid in world coordinates when the caller has built it (PipelineRun's world grid, the
  // geometry of mesh.vtu): simplex_grid of the mesh, or voxel_grid of the image. Null: the simulation
  // builds the same grid itself.
  std::shared_ptr<const UnstructuredGrid> world_grid;
  // The caller has checked the scenario against this image's box (check_scenario_geometry, and for
  // the voxel model check_modulus_image): the simulation does not check it again.
  bool scenario_checked = false;
  // More than 1 (mpirun): every rank builds the same simulation, the FEM solves run over mpi_comm
  // (fem::distribute_solves) and step files are .pvtu with this many .vtu pieces, each written by its rank.
  int mpi_ranks = 1;
  // The MPI_Comm of those ranks, given by the entry point (an MPI_Comm*, so that <mpi.h> stays out of
  // this header; cli.cpp takes it from StudyRanks). Null: one process (MPI_COMM_SELF, the voxel model's
  // multigrid on one rank).
  const void* mpi_comm = nullptr;
  // Such a run's memory per rank for MUMPS's factorisation, in bytes (fem::SolverOptions::max_memory:
  // solver.type auto factorises when MUMPS's estimate fits, direct refuses a model above it). 0 = no limit.
  double max_memory = 0.0;
  // On the ranks other than 0 of such a run with an output folder (rank 0 alone has output_file and
  // writes every other file): the path of a file relative to that folder, for this rank's pieces of
  // the step files. Empty otherwise.
  std::function<std::filesystem::path(const std::string& relative)> piece_file;
};

template <int dim>
struct NeedleRun {
  using Vec = Eigen::Matrix<double, dim, 1>;
  std::string name;
  Vec axis;                   // world, unit
  Vec entry = Vec::Zero();    // world: the planned line's entry point
  std::vector<double> depth;  // per step (step 0 = rest)
  std::vector<Vec> tip;       // world (the flexible needle: its bent end)
  // The flexible needle (needle.flexible), per step, world: the tip's deviation from the planned line,
  // its angle to that line (degrees), the lateral force and the bending moment its base holder applies
  // to it, and its shape (points along the needle from the base to the tip). Empty for a rigid needle.
  std::vector<Vec> tip_deviation, base_force, base_moment;
  std::vector<double> tip_angle;
  std::vector<std::vector<Vec>> shape;
  std::vector<Vec> force;                          // world: force of the tissue on the needle
  std::vector<double> axial_force, lateral_force;  // see the header comment
  // The axial force's parts: the shaft's friction (Σ over the shaft stations) and the tip's force (the
  // tissue the tip pushes until it is cut; the force model: the tip point); they sum to axial_force.
  std::vector<double> friction_force, tip_force;
  // A puncture: the first step at which the tip cuts after pressing the tissue without cutting (its
  // force reached the cutting force); the needle's depth then, and the axial force at the step
  // before and at that step.
  struct Puncture {
    double depth = 0.0, force_before = 0.0, force_after = 0.0;
  };
  std::vector<Puncture> punctures;
  std::vector<int> tip_cutting;  // per step: 1 where the tip cuts (its force held at the cutting force)
  std::vector<std::vector<Vec>> target_displacement;  // [step][target], world axes
  std::vector<std::vector<Vec>>
      vertex_displacement;         // world axes: every step if keep_step_fields, else the last
  std::vector<int> active_points;  // shaft points constrained at each step
  std::vector<int> solves;         // model solves per step (> 1 with sliding points)
  std::vector<int>
      active_set_sweeps;  // stick-slip: active-set sweeps per step (step 0 = rest; 0: sticking held)
  std::vector<int>
      unsettled_steps;  // stick-slip steps whose active set did not settle (see SimulationOptions)
  std::vector<double> point_s, point_length;  // shaft points: travel at pick-up, shaft length each stands for
  std::vector<int> point_tissue;  // per shaft point: its needle.tissues entry (-1: the needle's values)
  std::vector<std::vector<double>>
      point_axial_force;          // [step][point]: axial force on the body (0 if not active)
  double max_displacement = 0.0;  // largest vertex displacement norm over all steps
  // Per step: the largest principal strain magnitude in the tissue: over the cells (max |eigenvalue|
  // of each cell's centroid strain) and, 3D, on the needle's surface in the shaft's near field, which
  // the mesh does not resolve (near_field_strain); small-strain elasticity is valid only while it stays
  // below ~10%.
  std::vector<double> max_strain;
  std::vector<double> mesh_strain;  // per step: the cells' part of max_strain
  // 3D, per step: the near field's largest principal strain on the needle's surface, and the distance
  // from the axis within which it exceeds the small-strain limit (0: nowhere in the tissue).
  std::vector<double> near_field_strain, small_strain_radius;
  std::vector<std::vector<int>> target_in_near_field;  // [step][target]: 1 within that distance of the shaft
  double solve_seconds = 0.0;                          // total time in solves
  // The energy balance, per step from step 0 (docs/procedure.md, "Energy"), over the shaft points j with
  // f̄_j the mean of the point's axial force at the step's two ends (trapezoidal rule), Δd the needle's
  // travel and Δū_j that of the point's axial value (the tissue's, through the band's compliance, while it
  // is on the needle): so far, the needle's work Σ f̄_j Δd; the friction's dissipated work Σ f̄_j (Δd − Δū_j)
  // over the points on the needle at both ends of a step (force × slip); the same sum over the points
  // that join or leave it (the tissue at the tip taken up or let go). row_energy: ½ Σ f_j ū_j at each
  // step, the stored energy by Clapeyron's theorem when the needle's rows are the only load.
  std::vector<double> needle_work, dissipated_work, join_work, row_energy;
  // Before stepping: the model's factorisation (if not done yet) and every shaft row's column
  // (ElasticModel::precompute); 0 with the monolithic reference.
  double precompute_seconds = 0.0;
  double stepping_seconds = 0.0;     // the stepping loop alone (steps 1..n, outputs included)
  std::vector<double> step_seconds;  // wall time per step (step 0 = 0)
  double steps_per_second = 0.0;
  fem::SolverStats stats;  // of the last solve
  // A procedure's seeds (docs/procedure.md), in the order of their planned depths: released at the
  // withdrawal step at which the tip is back at or above the planned depth; the seed is the material
  // point X = P − u_release(P) of the tissue at the planned position P, and its final position, with the
  // tissue back at its rest state u_rest once the needle is out, X + u_rest(P) (linear model).
  struct Seed {
    double depth = 0.0;
    Vec planned = Vec::Zero();               // world
    Vec release_displacement = Vec::Zero();  // u_release(P), world axes
    Vec rest_displacement = Vec::Zero();     // u_rest(P): the tissue without the needle (step 0)
    int release_step = -1;
    Vec final_position() const { return planned - release_displacement + rest_displacement; }
    Vec error() const { return final_position() - planned; }
  };
  std::vector<Seed> seeds;
};

// A scenario without a needle: the model under its boundary conditions alone (step 0), solved once.
template <int dim>
struct StaticLoadRun {
  using Vec = Eigen::Matrix<double, dim, 1>;
  std::vector<Vec> target_displacement;  // per target, world axes
  std::vector<Vec> vertex_displacement;  // per model vertex, world axes
  double max_displacement = 0.0;         // largest vertex displacement norm
  double max_strain = 0.0;               // largest principal strain magnitude over the cells
  fem::SolverStats stats;
};

// One step of a procedure's probe motion (docs/procedure.md, the probe): the probe's pose from its start
// (translation, and angle about its axis), the force the tissue exerts on it (−Σ of the foundation's
// forces k w_p (b_p − u(x_p)) on the tissue) and the moment of those forces about the probe's axis centre
// (the cylinder's centre, moved with the probe; arms R(θ)(x_p − c)), world axes (2D: the moment's z
// component only), and the targets' displacements.
template <int dim>
struct ProbeStep {
  using Vec = Eigen::Matrix<double, dim, 1>;
  int action = 0;  // its action's index in `procedure`
  int step = 0;    // 1..steps of that action
  Vec translation = Vec::Zero();
  double angle = 0.0;  // degrees
  Vec force = Vec::Zero();
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  std::vector<Vec> target_displacement;  // per target, world axes
  double max_displacement = 0.0;         // largest vertex displacement norm
};

template <int dim>
struct SimulationResult {
  std::vector<NeedleRun<dim>> needles;
  std::vector<ProbeStep<dim>> probe_steps;        // a procedure's probe motions, every step in order
  std::optional<StaticLoadRun<dim>> static_load;  // the scenario has no needle
  std::vector<std::string> target_names;  // the scenario's targets, in the order of target_displacement
  std::vector<Eigen::Matrix<double, dim, 1>> target_positions;  // their rest positions, world
  std::vector<std::string> warnings;  // results the user should not take at face value (also in report)
  nlohmann::json report;              // for report.json["simulation"]
};

template <int dim>
class NeedleSimulation {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  // Simplex model (VIM or grid mesh) in the frame; per-cell modulus from model.values (Eq. 15 with
  // the scenario's scale and clamp) or the scenario's constant. Validates everything that needs the
  // mesh (regions that select no node, targets outside the mesh) and throws ScenarioError; writes nothing.
  NeedleSimulation(const MeshModel<dim>& model, const Scenario& scenario, SimulationOptions options = {});
  // Fine voxel reference model: one Q1 cell per voxel of `image`, E = voxel value × scale (clamped).
  // `labels`: the label image on `image`'s grid, for the scenario's label regions (docs/labels.md); the
  // moduli stay the image's.
  static NeedleSimulation voxel(const Image<dim>& image, const WorldTransform<dim>& transform,
                                const Scenario& scenario, SimulationOptions options = {},
                                std::shared_ptr<const Image<dim>> labels = nullptr);
  ~NeedleSimulation();
  NeedleSimulation(NeedleSimulation&&) noexcept;

  // Runs every needle of the scenario from rest, or without a needle the static load case (step 0);
  // writes the outputs when options.output_file is set.
  SimulationResult<dim> run();

  const std::vector<double>& youngs_modulus() const;  // per cell, as used
  fem::ElasticModel<dim>& model();

 private:
  NeedleSimulation();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Convenience: construct + run.
template <int dim>
SimulationResult<dim> run_simulation(const MeshModel<dim>& model, const Scenario& scenario,
                                     SimulationOptions options = {});

}  // namespace vim::pipeline

// Private to the simulation sources: the files and report entries of a needle simulation, apart from
// the physics — step VTUs (displacement, strain, stress, von Mises, modulus in world axes), needle.csv,
// summary.csv and the report.json entries.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vim/needle/friction_law.hpp>

#include "simulation/simulation_context.hpp"

namespace vim::pipeline {

// "step_0007.vtu", or "step_0007.pvtu" for a run on several MPI ranks (its pieces: write_pvtu)
std::string step_file(int k, int mpi_ranks = 1);

// The world grid with the scenario's output fields of a solution (zero fields when null: rest), written
// to ctx.opt.output_file(relative): a .vtu, or with ctx.opt.mpi_ranks > 1 a .pvtu with a piece per rank,
// each written by its rank (the cells it owns in the distributed solves, through
// ctx.opt.piece_file on the ranks other than 0): then collective over ctx.opt.mpi_comm.
template <int dim>
void write_step_vtu(const SimulationContext<dim>& ctx, const std::string& relative,
                    const fem::Solution<dim>* solution);

// "needle_0007.vtp": the needle at step k (write_needle_vtp), beside the step file.
std::string needle_step_file(int k);

// The needle at a step: one polyline through `shape` (world: from the needle's base to its tip) with
// point data `deflection`, each point's offset from the planned line through `entry` along the unit
// `axis` (world; zero for the rigid needle).
template <int dim>
void write_needle_vtp(const std::filesystem::path& path,
                      const std::vector<Eigen::Matrix<double, dim, 1>>& shape,
                      const Eigen::Matrix<double, dim, 1>& entry, const Eigen::Matrix<double, dim, 1>& axis);

// Whether this process writes step files: rank 0 of a run with an output folder (output_file), or
// another rank of such a run over MPI ranks (piece_file: its pieces of the .pvtu).
inline bool writes_steps(const SimulationOptions& o) {
  return static_cast<bool>(o.output_file) || static_cast<bool>(o.piece_file);
}

// Per step: depth, tip, axial and lateral force, the axial force's friction and tip parts, the largest
// strain (max_strain), each target's displacement and its norm.
template <int dim>
void write_needle_csv(const std::filesystem::path& path, const NeedleRun<dim>& run, const Scenario& sc);

// One row per needle of a needle list: final numbers.
template <int dim>
void write_summary_csv(const std::filesystem::path& path, const std::vector<NeedleRun<dim>>& needles,
                       const Scenario& sc);

// A procedure's seeds (NeedleRun::seeds): seeds.csv, one row per seed (needle, planned depth, planned
// position, position at release, final position, error vector and norm, release step), and the
// report.json entry: mean, RMS and largest error norm per needle and over all.
template <int dim>
void write_seeds_csv(const std::filesystem::path& path, const std::vector<NeedleRun<dim>>& needles);
// A procedure's seeds in a step (steps/seeds_NNNN.vtu beside the step file): one vertex cell per seed
// released so far at `position` (world), with point data `needle` (its needle's number) and `error`
// (position − planned).
template <int dim>
void write_seed_points(const std::filesystem::path& path,
                       const std::vector<Eigen::Matrix<double, dim, 1>>& position,
                       const std::vector<Eigen::Matrix<double, dim, 1>>& planned,
                       const std::vector<int>& needle);
template <int dim>
nlohmann::json seeds_report(const std::vector<NeedleRun<dim>>& needles);

// What one needle's insertion gives: its run and its entry of report.json["simulation"]["needles"].
template <int dim>
struct NeedleOutcome {
  NeedleRun<dim> run;
  nlohmann::json report;
  std::vector<std::string> warnings;  // the run summary's (what lies inside the bands)
};

// The needle's entry of report.json["simulation"]["needles"].
template <int dim>
nlohmann::json needle_report(const NeedleSpec& spec, const NeedleRun<dim>& run,
                             const needle::FrictionLaw& law, double pitch, const std::string& prefix,
                             double run_seconds, int solves, bool monolithic, const Scenario& sc);

// The model part of report.json["simulation"]: scenario, units, model kind, size and modulus range.
template <int dim>
nlohmann::json model_report(const SimulationContext<dim>& ctx);

}  // namespace vim::pipeline

// Private to the simulation sources: what NeedleSimulation (simulation.hpp) builds once and every
// needle insertion reads — the scenario, the FEM model in the image frame, point location, the
// boundary conditions' blocked vertices, the world grid of the output files (quadratic cells for P2).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <memory>
#include <optional>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/coupling.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/seconds_since.hpp>

namespace vim::pipeline {

template <int dim>
struct SimulationContext {
  using Vec = Eigen::Matrix<double, dim, 1>;
  using Mat = Eigen::Matrix<double, dim, dim>;
  Scenario sc;
  SimulationOptions opt;
  WorldTransform<dim> tf;
  std::optional<fem::ElasticModel<dim>> model;
  std::vector<double> E;                          // per cell, as used
  Vec box_min, box_max;                           // frame
  std::shared_ptr<const Image<dim>> label_image;  // --labels in the frame: label regions
  std::shared_ptr<const UnstructuredGrid> grid;   // world, no fields; its points are the model's vertices
  std::vector<std::array<int, 2>> edges;          // degree 2: vertex pairs of the grid's mid-edge points
  std::vector<bool> blocked;                      // vertices held in every direction
  std::vector<fem::Region<dim>> held_regions;     // regions held in every direction (clamped or supported)
  // Axes of the needle's point constraints: the world axes seen from the frame when a support holds
  // world components of an oblique image, so that a shaft point on such a node leaves the held
  // directions to the support (as on an axis-aligned image); else the frame axes.
  Mat point_axes = Mat::Identity();
  // A procedure's needles left in (stay: true): their stations' rows at the values of their last step,
  // held in every later insertion (docs/procedure.md).
  std::vector<fem::PointConstraint<dim>> staying;
  // Per needle left in: its coupling and last state (its rows are `rows` consecutive entries of
  // `staying`), so that the later runs read the tissue near it with its near field (the coupling's
  // tissue_displacements) as its own run did.
  struct StayingNeedle {
    std::shared_ptr<const needle::NeedleCoupling<dim>> coupling;
    needle::ShaftState state;
    std::size_t rows = 0;
  };
  std::vector<StayingNeedle> staying_needles;
  // A procedure's seeds released by the needles run so far (docs/procedure.md): the planned position P
  // (frame and world), the material point X = P − u_release(P) (world) and the needle's number (1, 2, …
  // in the procedure's order). A seed is at X + u(P) in any later state u of the tissue.
  struct ReleasedSeed {
    Vec planned_frame, planned, material;
    int needle = 0;
  };
  std::vector<ReleasedSeed> released;
  // The probe (Scenario::probe): its foundation, the model's volume support number `support` (points in
  // the frame, weights, k), its axis centre and unit axis at the start (world), and the pose its motions
  // have reached (translation, world; angle about the axis, degrees). The base follows the pose.
  struct Probe {
    std::size_t support = 0;
    std::vector<Vec> points;
    std::vector<double> weights;
    double stiffness = 0.0;
    Vec center = Vec::Zero(), axis = Vec::Zero();
    Vec translation = Vec::Zero();
    double angle = 0.0;
    bool moved() const { return angle != 0.0 || !translation.isZero(0.0); }
  };
  std::optional<Probe> probe;
  bool voxel = false;
  unsigned degree = 1;
  double build_seconds = 0.0;
  fem::SolverOptions solver;

  // Point location in the model's cells (the model's own locator: its vertices are the supports' numbering).
  const fem::CellLocator<dim>& locator() const { return model->locator(); }
  int max_sweeps() const { return std::max(1, opt.max_active_set_iterations); }  // stick-slip cap per step
  // A scenario region in the frame (regions are given in world coordinates; box faces name the box).
  fem::Region<dim> region(const RegionSpec& r) const;
};

}  // namespace vim::pipeline

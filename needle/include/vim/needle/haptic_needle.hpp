// A needle inserted at haptic rate into a precomputed tissue region (docs/performance.md, "Real-time
// needle"). The path is not known in advance: the constructor condenses the tissue onto a chosen region
// (DiMaio & Salcudean's condensation: W = the block of K⁻¹ on the region's DoFs, and u0 = K⁻¹f there,
// from one factorisation and blocks of right-hand sides), then each step() takes the needle's pose —
// its tip and direction — and returns the forces and the displacements of chosen probe points, with
// dense work on the region's W alone, no allocation after the first steps (the stations' capacity is
// reserved), and a bounded number of stick-slip sweeps.
//
// The needle model is the finite-diameter band coupling of docs/needle-model.md: a station joins the
// shaft each time the tip has travelled `spacing` along the track, centred on the track segment it
// passed; it holds the mean displacement of its band (rings of the coupling radius R around the axis
// at the time it joined) through the analytic annulus compliance in series (needle_band_constraint,
// the station's modulus the mean over the cells its samples fall in). Each step its tissue is held on
// the current needle axis across it (the lateral rows) and, axially, moves with the needle (stick: the
// needle's axial travel since the station joined, minus its slip) unless its axial load exceeds
// max_shear_per_length × spacing: it then slides at that limit (its slip accumulating); a sliding
// station whose limit would need it ahead of the needle sticks again. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <memory>
#include <vector>
#include <vim/fem/conditions.hpp>
#include <vim/fem/model.hpp>
#include <vim/needle/fem_types.hpp>

namespace vim::needle {

class HapticNeedle {
 public:
  struct Options {
    double radius = 0.5;           // a: the needle's radius
    double coupling_radius = 1.0;  // R ≥ a: outer radius of the bands
    double spacing = 1.0;          // station spacing along the track (the band length)
    double max_shear_per_length = std::numeric_limits<double>::infinity();  // stick-slip limit; ∞ = stick
    int max_sweeps = 8;             // stick-slip active-set sweeps per step (≥ 1)
    std::size_t max_stations = 64;  // capacity: stations beyond it do not join
  };
  struct Step {
    std::size_t stations = 0;           // stations on the shaft
    std::vector<Vec<3>> station_force;  // per station: the force on the tissue (model axes)
    Vec<3> force = Vec<3>::Zero();      // the force of the tissue on the needle, −Σ station_force
    std::vector<Vec<3>> probe_displacement;
    int sweeps = 0;             // active-set sweeps of this step
    bool settled = true;        // false: the set still changed after max_sweeps
    std::vector<bool> sliding;  // per station
  };

  // Condenses the model onto the DoFs of its cells whose centroid lies in `region`, and of the cells
  // holding the probes; the needle's bands must stay in those cells. Simplex models only. Throws
  // std::invalid_argument for a voxel model, bad options or a probe outside the mesh.
  HapticNeedle(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
               const Options& options, const fem::SolverOptions& solver = {});
  ~HapticNeedle();
  HapticNeedle(HapticNeedle&&) noexcept;

  // One step with the tip at `tip` and the shaft along the unit `direction` (towards the tip). The
  // first call marks the entry (no station yet). Throws std::invalid_argument when a band leaves the
  // region. The result stays valid until the next call.
  const Step& step(const Vec<3>& tip, const Vec<3>& direction);

  std::size_t region_dofs() const;
  // The last step's constraints (one per station: band samples, axes, compliances and the values held:
  // lateral across the axis, axial the needle-side value), for fem::ElasticModel::solve_monolithic.
  std::vector<PointConstraint<3>> constraints() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::needle

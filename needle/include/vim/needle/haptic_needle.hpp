// A needle inserted at haptic rate into a precomputed tissue region (docs/performance.md, "Real-time
// needle"). The path is not known in advance: the constructor condenses the tissue onto a chosen region
// (DiMaio & Salcudean's condensation: W = the block of K⁻¹ on the region's DoFs, and u0 = K⁻¹f there,
// from one factorisation and blocks of right-hand sides), then each step() takes the needle's pose —
// its tip and direction — and returns the forces and the displacements of chosen probe points, with
// dense work on the region's W alone and no allocation after the first steps (every capacity is
// reserved for max_stations).
//
// The needle model is the CLI's (docs/needle-model.md): the stepping is needle::Insertion (which
// stations are on the needle, the values that move them with it, the shaft length each carries), the
// active set is the registered friction law's (make_friction_law, the same FrictionOptions as a
// scenario's needle), and each station is a band of BandCoupling's kind (station_band: the given
// coupling radius or the default band rule from the element size and the model's degree; the analytic
// annulus compliance in series, the station's modulus the mean over the cells its samples fall in).
// Only the tissue is the haptic one: a TissueResponse on the condensed region whose rows follow the
// pose. Station j stands for arc length [j·ℓ, (j + 1)·ℓ] of the needle's axial travel; its band is
// placed on the current pose's axis the first time the stepping reads its tissue, and from then on its
// tissue is held on the current needle axis across it (the lateral rows) and axially at the value the
// law gives it. With a cutting force the tip has the CLI's end bearing (BandCoupling::tip_rows,
// vim/needle/tip_bearing.hpp): disks every tip_spacing of travel from the entry, those of the first
// pose's axis that lie in the tissue (at least half of their samples in the mesh), their depth below the
// free surface measured along that axis; the disk the tip presses is placed on the current axis when the
// tip reaches it, and once the tip presses a disk every station up to the cut is placed before the law's
// solve (a puncture joins the tissue it cuts within that solve).
//
// A flexible needle (Options::flexible) is the CLI's (vim/needle/flexible/flexible_tissue.hpp): an
// Euler–Bernoulli beam clamped where the haptic device (or a template) holds it, solved with the
// stations' lateral forces in one system per tissue solve, a bevel's lateral tip load, the channel the
// tip cuts along its own tangent. It steps by the base's pose (step(const BasePose&)): the planned line
// is the first pose's axis, the stations lie on it as the CLI's do, and the beam's base is held at the
// pose's position and direction (its offset and slope from the planned line, small-deflection theory).
// The flexible step allocates (its beam grows with the depth). deal.II-free.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <optional>
#include <vector>
#include <vim/fem/conditions.hpp>
#include <vim/fem/model.hpp>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/flexible/flexible_tissue.hpp>
#include <vim/needle/friction_law.hpp>
#include <vim/needle/shaft_state.hpp>

namespace vim::needle {

class HapticNeedle {
 public:
  struct Options {
    double radius = 0.5;            // a: the needle's radius
    double coupling_radius = 0.0;   // R ≥ a of the bands; 0: the default band (station_band)
    double element_size = 0.0;      // h near the path, for the default band (needed when R is 0)
    double spacing = 1.0;           // station length ℓ along the needle's travel
    FrictionOptions friction;       // the law and its parameters, as a scenario's needle gives them
    std::size_t max_stations = 64;  // capacity: stations beyond it do not join
    // The tip bearing's disks (with a cutting force) every tip_spacing of travel; 0: half the element
    // size, at most half the disk radius (the CLI takes min(h/2, depth / steps)).
    double tip_spacing = 0.0;
    // A flexible needle: its tube (E, inner diameter; the outer diameter is 2·radius, free_length is
    // taken from each pose). Absent: the rigid needle, stepped by its tip.
    std::optional<FlexibleNeedle> flexible;
    double bevel_angle = 90.0;  // degrees, in (0, 90]; 90: a symmetric tip (no lateral load)
  };
  // Where a flexible needle is held: the holder's position, the needle's direction there (towards the
  // tip), the needle's length from the holder to its tip (fixed for a device gripping the hub; growing
  // for a template the needle slides through), and the side the bevel faces (normal to the needle, unit
  // or 0; the device's roll turns it).
  struct BasePose {
    Vec<3> position = Vec<3>::Zero(), direction = Vec<3>::UnitZ();
    double length = 0.0;
    Vec<3> bevel_side = Vec<3>::Zero();
  };
  struct Step {
    std::size_t stations = 0;           // stations on the shaft (the stepping's active shaft points)
    std::vector<Vec<3>> station_force;  // per active station, in shaft order: the force on the tissue
    Vec<3> tip_force = Vec<3>::Zero();  // the force on the tissue the tip presses (0: it presses none)
    bool tip_cutting = false;           // the tip cuts, held at the cutting force
    Vec<3> force = Vec<3>::Zero();  // the force of the tissue on the needle, −(Σ station_force + tip_force)
    std::vector<Vec<3>> probe_displacement;
    int sweeps = 0;       // the law's active-set sweeps of this step
    bool settled = true;  // false: the set still changed after max_sweeps
    // The needle's tip (a flexible needle's bent one; before it touches the tissue the straight one),
    // its deviation from the planned line, its angle to it (degrees), and the lateral force and moment
    // the holder applies to the needle (a flexible needle's; 0 for the rigid one).
    Vec<3> tip = Vec<3>::Zero(), tip_deviation = Vec<3>::Zero();
    double tip_angle = 0.0;
    Vec<3> base_force = Vec<3>::Zero(), base_moment = Vec<3>::Zero();
  };

  // Condenses the model onto the DoFs of its cells whose centroid lies in `region`, and of the cells
  // holding the probes; the needle's bands must stay in those cells. Simplex models only. Throws
  // std::invalid_argument for a voxel model, bad options, an unknown law or a probe outside the mesh.
  HapticNeedle(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
               const Options& options, const fem::SolverOptions& solver = {});
  ~HapticNeedle();
  HapticNeedle(HapticNeedle&&) noexcept;

  // One step with the tip at `tip` and the shaft along the unit `direction` (towards the tip). The
  // first call marks the entry (travel 0). The needle's travel advances by the tip's motion along
  // `direction`. Throws std::invalid_argument when a band leaves the region. The result stays valid
  // until the next call.
  // A rigid needle only (std::logic_error otherwise).
  const Step& step(const Vec<3>& tip, const Vec<3>& direction);
  // A flexible needle only (std::logic_error otherwise): the straight tip position + length·direction
  // steps as step(tip, direction) does along the planned line (the first pose's direction); the first
  // call marks the entry. Throws std::invalid_argument for a holder past the entry or a bad pose.
  const Step& step(const BasePose& base);

  std::size_t region_dofs() const;
  // The stepping's state after the last step (active stations, their axial values and carried lengths).
  const ShaftState& state() const;
  // The last step's constraints (one per active station: band samples, axes, compliances and the values
  // held: lateral across the axis, axial the law's value; then the tip's disk, axial only, if it
  // presses one), for fem::ElasticModel::solve_monolithic.
  std::vector<PointConstraint<3>> constraints() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::needle

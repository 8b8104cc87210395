// How the needle acts on the tissue (docs/architecture.md, needle coupling). The stepping loop
// (NeedleSimulation::run) advances the tip and picks up the embedded shaft points; at each step
//  * a FrictionLaw chooses the axial value of every active shaft point (how far along the needle axis
//    the tissue there is moved): stuck to the needle, sliding at a friction limit, or loaded by a
//    prescribed friction and tip force; it asks the tissue for its response through TissueResponse;
//  * a NeedleCoupling turns those values into the point-constraint rows of the model solve: a line of
//    points in 2D (LineCoupling), bands of a cylinder around the shaft in 3D (BandCoupling).
// The laws and couplings are dimension-free or templated on dim alone and never see the loop: a new
// law is one class in its own file and one line in make_friction_law (friction_law.cpp).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/fem/needle_band.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/needle.hpp>

namespace vim::pipeline {

// The shaft points as the loop hands them to a friction law at one step. Per-point vectors have one
// entry per shaft point (in shaft order); only those of `active` points mean anything at this step.
struct ShaftState {
  std::vector<std::size_t> active;  // points on the needle at this step, in shaft order
  std::size_t tip = 0;              // the last active point (the one nearest the tip)
  // The active point the tip pushes until it is cut (kinematic model with a cutting force): it moves
  // with the needle until its axial force reaches the cutting force, then it is held at that force
  // (the law's limit for it). None (any index ≥ the number of points) when the cutting force is 0: the
  // tissue at the tip is then cut without resistance and not held.
  std::size_t cutting = std::numeric_limits<std::size_t>::max();
  std::vector<bool> joined;     // picked up at this step
  std::vector<double> axial;    // axial constraint value: kept between steps, set by the law
  std::vector<double> stick;    // the value that moves the point with the needle at this step
  std::vector<double> carried;  // shaft length the point carries (its segment up to the tip)

  // Moves a point with the needle (it sticks).
  void stick_to_needle(std::size_t j) { axial[j] = stick[j]; }
  // The entries of the active points, in the order of `active`, and back.
  Eigen::VectorXd compact(const std::vector<double>& v) const;
  void expand(const Eigen::VectorXd& c, std::vector<double>& v) const;
};

// The tissue's answer to axial values of the active shaft points, for a friction law.
class TissueResponse {
 public:
  virtual ~TissueResponse() = default;
  // One model solve with the active points at `axial`; the axial force on the body per shaft point
  // (0 for points not active). The last call of a step is the step's solution.
  virtual std::vector<double> solve(const std::vector<double>& axial) = 0;
  // The affine map from the active points' axial values to their axial forces (needle.hpp), probed
  // with m + 1 solves when the number of active points m has changed since the last probe.
  virtual const AxialMap& axial_map() = 0;
};

// What a law did at one step (stick-slip: the active-set sweeps and whether the set settled).
struct FrictionStep {
  int sweeps = 0;
  bool settled = true;
};

// A friction law between the shaft and the tissue: it sets `state.axial` of the active points and
// leaves the tissue solved with those values (its last TissueResponse::solve).
class FrictionLaw {
 public:
  virtual ~FrictionLaw() = default;
  // Called once before the first step with the number of shaft points.
  virtual void start(std::size_t n_points) = 0;
  virtual FrictionStep update(ShaftState& state, TissueResponse& tissue) = 0;
  // The law keeps an active set whose sweeps are recorded per step (NeedleRun::active_set_sweeps).
  virtual bool has_active_set() const { return false; }
  // The axial force of a needle advancing under this law never falls in linear elastic tissue (the
  // simulation warns where the discretisation makes it fall).
  virtual bool axial_force_never_falls() const { return false; }
  // The law's keys of the needle's report.json entry ("model", "friction", its parameters).
  virtual void describe(nlohmann::json& needle_report) const = 0;
};

// The law of a needle of the scenario (needle.model, needle.friction and their parameters);
// max_active_set_iterations caps the stick-slip sweeps per step.
std::unique_ptr<FrictionLaw> make_friction_law(const NeedleSpec& spec, int max_active_set_iterations);

// The rows a needle imposes on the model at one step.
template <int dim>
class NeedleCoupling {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  virtual ~NeedleCoupling() = default;
  // The point constraints that hold the active points at their axial values (several rows per shaft
  // point are allowed: the forces are summed back per point by axial_forces).
  std::vector<fem::PointConstraint<dim>> rows(const std::vector<std::size_t>& active,
                                              const std::vector<double>& axial) const;
  // The same rows' displacements alone (PointConstraint::displacement, in each row's axes), written
  // into `held` (one per active point): what a step changes in rows that keep their geometry.
  virtual void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                           std::vector<Vec>& held) const = 0;
  // The constraint of shaft point j with displacement 0.
  virtual const fem::PointConstraint<dim>& row_template(std::size_t j) const = 0;
  // Per shaft point: the axial force on the body of its rows in a solution of rows(active, ·).
  virtual std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                           const fem::Solution<dim>& solution) const = 0;
  // The tissue displacement the rows of `points` hold (the point's, or its band's mean) in the model's
  // last solution: where the tissue of a shaft point is before the needle takes it.
  virtual std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                         const fem::ElasticModel<dim>& model) const = 0;
  // The tissue displacement at each shaft point before the needle touches it (the external loads):
  // the rows keep its part across the axis rather than pulling the tissue back to the rest line.
  virtual void keep_offsets(const std::vector<Vec>& displacement) = 0;
  // The tissue displacement at `points` (frame) given the model's values there, `mesh_values`, in a
  // solution of rows(active, axial): a coupling whose rows stand for an analytic near field replaces
  // the model's value where the near field holds (BandCoupling); the line leaves them as they are.
  virtual std::vector<Vec> tissue_displacements(const std::vector<Vec>& points, std::vector<Vec> mesh_values,
                                                const ShaftState& state,
                                                const fem::Solution<dim>& solution) const {
    (void)points, (void)state, (void)solution;
    return mesh_values;
  }
};

// A thin straight needle: one point constraint per shaft point, holding it on the needle's axis line
// (lateral displacement 0, or the loads' offset) at its axial value along `axis`. `axes` are the
// constraint axes (the frame axes, or the world axes seen from the frame on an oblique image whose
// supports hold world components).
template <int dim>
class LineCoupling final : public NeedleCoupling<dim> {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  using Mat = Eigen::Matrix<double, dim, dim>;
  LineCoupling(std::vector<Vec> positions, const Vec& axis, const Mat& axes);
  void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                   std::vector<Vec>& held) const override;
  const fem::PointConstraint<dim>& row_template(std::size_t j) const override { return points_[j]; }
  std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                   const fem::Solution<dim>& solution) const override;
  std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                 const fem::ElasticModel<dim>& model) const override;
  void keep_offsets(const std::vector<Vec>& displacement) override;

 private:
  std::vector<fem::PointConstraint<dim>> points_;  // per point, displacement 0
  std::vector<Vec> lateral_;
  Vec axis_;
  Mat axes_;
};

// A straight needle of radius a in 3D (docs/needle-model.md): shaft stations along the path (Geometry),
// each holding the mean displacement of its band of the cylinder of coupling radius R ≥ a around the
// axis (its segment of the shaft) through the analytic compliance of the annulus a ≤ r ≤ R in series
// (fem::needle_band_constraint): three rows per station (two lateral, one axial). A line carries no
// force in a 3D continuum; a band does, and the radius enters through the compliance, so the forces
// converge under mesh refinement. Stations whose band lies wholly outside the mesh or in held cells
// (every vertex of every cell its samples fall in held) are left out.
class BandCoupling final : public NeedleCoupling<3> {
 public:
  struct Geometry {
    Vec entry, axis;      // frame; axis of unit length
    double depth = 0.0;   // the path's length
    double radius = 0.0;  // a = diameter / 2
    // R ≥ a: each station holds the mean over the surface of radius R; 0 = fem::default_needle_band
    // from the element size h near the path and the element degree (docs/needle-model.md).
    double coupling_radius = 0.0;
    double element_size = 0.0;  // h
    unsigned degree = 1;
    double spacing = 0.0;  // station spacing along the path (made uniform: depth / stations)
    // The frame-to-world rotation: the bands' samples are placed around the needle in world axes, so
    // that a model in frame coordinates and the same body in world coordinates sample alike.
    Eigen::Matrix3d to_world = Eigen::Matrix3d::Identity();
  };
  // `cell_modulus`: Young's modulus per cell of the locator (the band's compliance takes the mean over
  // the cells its samples fall in); `blocked`: vertices held in every direction; `held_regions`: the
  // regions held in every direction (clamped or elastically supported).
  BandCoupling(const Geometry& geometry, const fem::CellLocator<3>& locator,
               const std::vector<double>& cell_modulus, double poisson_ratio,
               const std::vector<bool>& blocked, std::vector<fem::Region<3>> held_regions = {});
  // The stations: centre, arc length of the centre, band length.
  const std::vector<ShaftPoint<3>>& stations() const { return stations_; }
  // The outer radius of the region whose mean a station holds.
  double coupling_radius() const { return coupling_radius_; }
  void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                   std::vector<Vec>& held) const override;
  const fem::PointConstraint<3>& row_template(std::size_t j) const override { return bands_[j]; }
  std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                   const fem::Solution<3>& solution) const override;
  std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                 const fem::ElasticModel<3>& model) const override;
  void keep_offsets(const std::vector<Vec>& displacement) override;
  // Within the effective radius R_e of the active stations' bands (from the first one's start to the
  // last one's end: the tissue the needle holds) the model holds only the band means ū; the tissue there
  // follows the annulus solution between the needle's surface (r = a, where it sits at the rows' value
  // g) and R_e (at ū):
  //   u(r) = ū + φ(r)(g − ū),  φ(r) = ln(R_e / max(r, a)) / ln(R_e / a),  g − ū = κ f per row,
  // linear in the arc length between station centres (docs/needle-model.md, target displacements).
  // Beside the held shaft beyond R_e: the model's value. Ahead of the held shaft's end or behind its
  // start: the model's value plus the near field it misses where it spreads each station's force f over
  // the band rather than the needle's surface, Σ w [K_a(x) − K_R(x)] f over the stations near x (K the
  // Kelvin field of the load's region; w = 0 in a held region, else from 1 to 0 as the station is
  // two to three times farther from x than the nearest held vertex is).
  std::vector<Vec> tissue_displacements(const std::vector<Vec>& points, std::vector<Vec> mesh_values,
                                        const ShaftState& state,
                                        const fem::Solution<3>& solution) const override;

 private:
  struct StationState {
    double s;     // arc length of the centre
    Vec g, jump;  // frame: the rows' value g and g − ū
  };
  Vec annulus_value(const std::vector<StationState>& st, double t, double r) const;
  Vec surface_load_correction(const Vec& x, const ShaftState& state, const fem::Solution<3>& solution) const;
  void add_stations(const Geometry& geometry, const fem::CellLocator<3>& locator,
                    const std::vector<double>& cell_modulus, double poisson_ratio,
                    const std::vector<bool>& blocked);
  std::vector<StationState> station_states(const std::vector<std::size_t>& active,
                                           const std::vector<double>& axial,
                                           const fem::Solution<3>& solution) const;

  std::vector<ShaftPoint<3>> stations_;
  std::vector<fem::PointConstraint<3>> bands_;  // per station, displacement 0
  fem::NeedleBand band_;                        // every station's band region (around the world axis)
  std::vector<double> moduli_;                  // per station: the mean modulus around its band
  std::vector<Vec> held_points_;                // vertices held in every direction
  std::vector<fem::Region<3>> held_regions_;
  std::vector<Vec> lateral_;
  Vec axis_;
  double coupling_radius_ = 0.0;
  double radius_ = 0.0;            // a
  double effective_radius_ = 0.0;  // R_e of the bands (fem::effective_coupling_radius)
  double poisson_ratio_ = 0.0;
};

}  // namespace vim::pipeline

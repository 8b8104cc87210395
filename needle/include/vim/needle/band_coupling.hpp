// The coupling of a 3D needle of finite radius: band stations (docs/needle-model.md).
#pragma once

#include <vim/fem/conditions.hpp>
#include <vim/needle/coupling.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/needle/shaft.hpp>

namespace vim::needle {

// A straight needle of radius a in 3D (docs/needle-model.md): shaft stations along the path (Geometry),
// each holding the mean displacement of its band of the cylinder of coupling radius R ≥ a around the
// axis (its segment of the shaft) through the analytic compliance of the annulus a ≤ r ≤ R in series
// (needle_band_constraint): three rows per station (two lateral, one axial). A line carries no
// force in a 3D continuum; a band does, and the radius enters through the compliance, so the forces
// converge under mesh refinement. Stations whose band lies wholly outside the mesh or in held cells
// (every vertex of every cell its samples fall in held) are left out.
class BandCoupling final : public NeedleCoupling<3> {
 public:
  struct Geometry {
    Vec entry, axis;      // frame; axis of unit length
    double depth = 0.0;   // the path's length
    double radius = 0.0;  // a = diameter / 2
    // R ≥ a: each station holds the mean over the surface of radius R; 0 = default_needle_band
    // from the element size h near the path and the element degree (docs/needle-model.md).
    double coupling_radius = 0.0;
    double element_size = 0.0;  // h
    unsigned degree = 1;
    double spacing = 0.0;  // station spacing along the path (made uniform: depth / stations)
    // The frame-to-world rotation: the bands' samples are placed around the needle in world axes, so
    // that a model in frame coordinates and the same body in world coordinates sample alike.
    Eigen::Matrix3d to_world = Eigen::Matrix3d::Identity();
    // The tip bearing (tip_bearing.hpp): > 0 adds tip rows, disks normal to the axis every tip_spacing
    // along the path (from the entry on), one of which the tip presses at a time (the one nearest the
    // tissue point ahead of the tip); 0: none (the tip cuts without resistance).
    double tip_spacing = 0.0;
  };
  // `cell_modulus`: Young's modulus per cell of the locator (the band's compliance takes the mean over
  // the cells its samples fall in); `blocked`: vertices held in every direction; `held_regions`: the
  // regions held in every direction (clamped or elastically supported).
  BandCoupling(const Geometry& geometry, const CellLocator<3>& locator,
               const std::vector<double>& cell_modulus, double poisson_ratio,
               const std::vector<bool>& blocked, std::vector<fem::Region<3>> held_regions = {});
  // The stations: centre, arc length of the centre, band length.
  const std::vector<ShaftPoint<3>>& stations() const { return stations_; }
  // The tip rows (points stations().size() + k of the coupling): disk centre and its arc length.
  const std::vector<ShaftPoint<3>>& tip_rows() const { return tips_; }
  // The radius of the tip rows' disks.
  double tip_disk_radius() const { return tip_disk_radius_; }
  // The outer radius of the region whose mean a station holds.
  double coupling_radius() const { return coupling_radius_; }
  void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                   std::vector<Vec>& held) const override;
  const fem::PointConstraint<3>& row_template(std::size_t j) const override {
    return j < bands_.size() ? bands_[j] : tip_bands_[j - bands_.size()];
  }
  std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                   const fem::Solution<3>& solution) const override;
  std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                 const fem::ElasticModel<3>& model) const override;
  void keep_offsets(const std::vector<Vec>& displacement) override;
  // Within the effective radius R_e of the active stations' bands (from the first one's start to the
  // end of the last one's cut part: the tissue the needle holds) the model holds only the band means ū; the
  // tissue there follows the annulus solution between the needle's surface (r = a, where it sits at the rows'
  // value g) and R_e (at ū):
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
  void add_stations(const Geometry& geometry, const CellLocator<3>& locator,
                    const std::vector<double>& cell_modulus, double poisson_ratio,
                    const std::vector<bool>& blocked);
  void add_tip_rows(const Geometry& geometry, const CellLocator<3>& locator,
                    const std::vector<double>& cell_modulus, double poisson_ratio);
  std::vector<StationState> station_states(const std::vector<std::size_t>& active,
                                           const std::vector<double>& axial,
                                           const fem::Solution<3>& solution) const;

  std::vector<ShaftPoint<3>> stations_;
  std::vector<fem::PointConstraint<3>> bands_;      // per station, displacement 0
  std::vector<ShaftPoint<3>> tips_;                 // the tip rows' disk centres
  std::vector<fem::PointConstraint<3>> tip_bands_;  // per tip row: axial only
  double tip_disk_radius_ = 0.0;
  NeedleBand band_;               // every station's band region (around the world axis)
  std::vector<double> moduli_;    // per station: the mean modulus around its band
  std::vector<Vec> held_points_;  // vertices held in every direction
  std::vector<fem::Region<3>> held_regions_;
  std::vector<Vec> lateral_;
  Vec axis_;
  double coupling_radius_ = 0.0;
  double radius_ = 0.0;            // a
  double effective_radius_ = 0.0;  // R_e of the bands (effective_coupling_radius)
  double poisson_ratio_ = 0.0;
};

}  // namespace vim::needle

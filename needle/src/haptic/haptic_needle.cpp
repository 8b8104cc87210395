// A needle at haptic rate in a condensed tissue region (vim/needle/haptic_needle.hpp): needle::Insertion
// and the registered friction law step it; the tissue behind needle::TissueResponse is the region's
// (haptic::RegionTissue, region_tissue.hpp), and a flexible needle's beam (FlexibleTissue) bends on it.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <vim/needle/flexible/flexible_tissue.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/insertion.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/needle/tip_bearing.hpp>

#include "region_tissue.hpp"

namespace vim::needle {

using haptic::Pattern;
using haptic::pattern_of;
using haptic::RegionTissue;

namespace {

// The stepping's options for a needle whose path is its travel: stations j·ℓ … (j + 1)·ℓ.
NeedleOptions<3> stepping_options(const HapticNeedle::Options& o) {
  NeedleOptions<3> n;
  n.path.entry = Vec<3>::Zero();
  n.path.axis = Vec<3>::UnitZ();
  n.path.depth = o.spacing * static_cast<double>(o.max_stations);
  n.steps = static_cast<int>(o.max_stations);
  n.diameter = 2.0 * o.radius;
  n.sample_spacing = o.spacing;
  n.coupling_radius = o.coupling_radius;
  n.friction = o.friction;
  return n;
}

std::vector<ShaftPoint<3>> stations(const HapticNeedle::Options& o) {
  std::vector<ShaftPoint<3>> shaft(o.max_stations);
  for (std::size_t j = 0; j < shaft.size(); ++j) {
    shaft[j].s = (static_cast<double>(j) + 0.5) * o.spacing;
    shaft[j].length = o.spacing;
    shaft[j].position = shaft[j].s * Vec<3>::UnitZ();
  }
  return shaft;
}

const HapticNeedle::Options& checked(const HapticNeedle::Options& o) {
  if (!(o.spacing > 0.0) || !(o.radius > 0.0) || o.max_stations == 0 || !(o.tip_spacing >= 0.0))
    throw std::invalid_argument(
        "HapticNeedle: radius and spacing must be > 0, tip_spacing >= 0 and max_stations >= 1");
  if (o.flexible && (!(o.flexible->youngs_modulus > 0.0) || !(o.flexible->inner_diameter >= 0.0) ||
                     !(o.flexible->inner_diameter < 2.0 * o.radius)))
    throw std::invalid_argument(
        "HapticNeedle: flexible needs youngs_modulus > 0 and 0 <= inner_diameter < 2 radius");
  if (!(o.bevel_angle > 0.0 && o.bevel_angle <= 90.0))
    throw std::invalid_argument("HapticNeedle: bevel_angle must be in (0, 90] degrees");
  return o;
}

// The tip bearing acts when the law cuts (a cutting force), as the CLI's coupling has its tip rows then.
bool has_tip_bearing(const HapticNeedle::Options& o) {
  return o.friction.cuts() && o.friction.law != "force";
}

}  // namespace

struct HapticNeedle::Impl {
  Impl(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
       const Options& o, const fem::SolverOptions& solver)
      : opt(checked(o)),
        band(station_band(o.radius, o.coupling_radius, o.element_size, o.spacing, model.degree())),
        disk_radius(tip_disk_radius(band.coupling_radius, o.radius)),
        disk(pattern_of(tip_bearing_constraint(Vec<3>::Zero(), Vec<3>::UnitZ(), o.radius, disk_radius,
                                               tip_sample_spacing(o.element_size, disk_radius), 1.0,
                                               model.poisson_ratio(), 0.0))),
        tip_spacing(o.tip_spacing > 0.0 ? o.tip_spacing : tip_sample_spacing(o.element_size, disk_radius)),
        poisson_ratio(model.poisson_ratio()),
        locator(model.locator()),
        tissue(model, region, probes, solver, band, disk, o.max_stations) {}
  Options opt;
  NeedleBand band;
  double disk_radius;
  Pattern disk;  // the tip's disk
  double tip_spacing, poisson_ratio;
  const CellLocator<3>& locator;
  std::optional<Insertion<3>> stepping;  // from the first call (the tip's disks along the first pose)
  std::vector<double> disk_s;            // arc length of each tip disk's centre
  double surface = 0.0;                  // where the first pose's axis enters the mesh (free_surface_along)
  RegionTissue tissue;
  Vec<3> tip = Vec<3>::Zero(), axis = Vec<3>::UnitZ();
  double depth = 0.0;  // the needle's travel along its axis
  Step result;
  // A flexible needle: its beam on the region's rows (from the first pose), and the entry.
  std::optional<FlexibleTissue> bending;
  Vec<3> entry = Vec<3>::Zero();

  void make_bending() {
    FlexibleNeedle tube = *opt.flexible;
    tube.outer_diameter = 2.0 * opt.radius;
    bending.emplace(tissue, stepping->state(), stations(opt), axis, tube, opt.spacing, stepping->n_points(),
                    opt.spacing);
  }
  // The stepping's pick-up with the needle's tip at `at` on the current axis; true when a point is on
  // the needle (its bands placed), false when none is (the tissue cleared).
  bool pick_up(const Vec<3>& at, double travel);
  // The law's solve on `response`, then the step's forces and probes.
  void solve(TissueResponse& response);
  // A flexible needle's beam for the pose `base` (a point is on the needle).
  void bend(const BasePose& base, double free_length);
  // The flexible needle's tip, deviation, angle and base loads of the last solve (`bent`: the beam was
  // solved at this depth).
  void record_bending(bool bent);

  // The first call: the stepping, with the tip's disks every tip_spacing of travel from the entry along
  // the first pose's axis that lie in the tissue (BandCoupling::tip_rows' rule).
  void start(const Vec<3>& entry) {
    std::vector<ShaftPoint<3>> tips;
    if (has_tip_bearing(opt)) {
      const double length = opt.spacing * static_cast<double>(opt.max_stations);
      surface = free_surface_along(locator, entry, axis, length);
      const Eigen::Matrix3d frame = needle_frame(axis);
      const long n = static_cast<long>(std::floor(length / tip_spacing + 1e-9)) + 1;
      for (long k = 0; k < n; ++k) {
        const double s = static_cast<double>(k) * tip_spacing;
        std::size_t inside = 0;
        for (const Vec<3>& off : disk.offsets) inside += locator.locate(entry + s * axis + frame * off) >= 0;
        if (!tip_disk_in_tissue(inside, disk.offsets.size())) continue;
        tips.push_back({entry + s * axis, s, 0.0});
        disk_s.push_back(s);
      }
    }
    stepping.emplace(stepping_options(opt), stations(opt), std::move(tips));
    tissue.attach(stepping->state(), stepping->n_points());
  }
  // Places the bands of stations up to j on the current axis, at their arc length behind the tip.
  void place_up_to(std::size_t j) {
    while (tissue.placed() <= j && tissue.placed() < opt.max_stations) {
      const double s = (static_cast<double>(tissue.placed()) + 0.5) * opt.spacing;
      tissue.place(tip - (depth - s) * axis, axis);
    }
  }
  // The disk the tip presses (if it is not the one placed) on the current axis at its arc length.
  void place_tip() {
    const std::size_t c = stepping->state().cutting;
    if (c < opt.max_stations || c >= stepping->n_points() || c == tissue.tip_index()) return;
    const double s = disk_s[c - opt.max_stations];
    tissue.place_tip(
        c, tip - (depth - s) * axis, axis,
        tip_bearing_compliance(opt.radius, disk_radius, 1.0, poisson_ratio, std::max(0.0, s - surface)));
  }
};

HapticNeedle::HapticNeedle(fem::ElasticModel<3>& model, const fem::Region<3>& region,
                           const std::vector<Vec<3>>& probes, const Options& o,
                           const fem::SolverOptions& solver)
    : impl_(std::make_unique<Impl>(model, region, probes, o, solver)) {
  Step& r = impl_->result;
  r.station_force.reserve(o.max_stations);
  r.probe_displacement.resize(probes.size());
  for (std::size_t p = 0; p < probes.size(); ++p)
    r.probe_displacement[p] = impl_->tissue.probe_displacement(p);
}

HapticNeedle::~HapticNeedle() = default;
HapticNeedle::HapticNeedle(HapticNeedle&&) noexcept = default;

std::size_t HapticNeedle::region_dofs() const { return impl_->tissue.slots(); }
const ShaftState& HapticNeedle::state() const {
  static const ShaftState none;
  return impl_->stepping ? impl_->stepping->state() : none;
}

bool HapticNeedle::Impl::pick_up(const Vec<3>& at, double travel) {
  depth += travel;
  tip = at;
  tissue.set_pose(at, needle_frame(axis));
  // The stepping reads the tissue of a station before it joins: its band is placed then.
  stepping->pick_up(depth, travel, [this](std::size_t j) {
    if (j >= opt.max_stations) return 0.0;
    place_up_to(j);
    return tissue.held_axial(j);
  });
  const ShaftState& state = stepping->state();
  result.sweeps = 0, result.settled = true;
  if (state.active.empty()) {
    tissue.clear();
    return false;
  }
  if (state.tip < opt.max_stations) place_up_to(state.tip);
  place_tip();
  // A puncture joins the tissue it cuts within the solve: every station the tip may reach is placed.
  const double cut = depth - opt.friction.cutting_distance;
  if (tissue.tip_index() < stepping->n_points() && cut > 0.0)
    place_up_to(static_cast<std::size_t>(cut / opt.spacing));
  return true;
}

void HapticNeedle::Impl::solve(TissueResponse& response) {
  const ShaftState& state = stepping->state();
  Step& out = result;
  if (!state.active.empty()) {
    const FrictionStep fs = stepping->solve(response);
    out.sweeps = fs.sweeps, out.settled = fs.settled;
  }
  // After the solve: the active set may have grown (the tissue a puncture cut joins).
  out.stations = 0;
  out.station_force.clear();
  out.tip_force.setZero();
  for (std::size_t j : state.active) {
    if (j < opt.max_stations)
      out.station_force.push_back(tissue.point_force(j)), ++out.stations;
    else
      out.tip_force = tissue.point_force(j);
  }
  out.tip_cutting = state.tip_cutting;
  out.force = -out.tip_force;
  for (const Vec<3>& f : out.station_force) out.force -= f;
  for (std::size_t p = 0; p < out.probe_displacement.size(); ++p)
    out.probe_displacement[p] = tissue.probe_displacement(p);
  out.tip = tip;
}

// As the CLI's bend(): the tissue pushes on the bevel's face, whose outward normal's lateral part is
// the bevel side: the lateral force on the needle is along −side, cot(angle) × the tip's axial force.
void HapticNeedle::Impl::bend(const BasePose& base, double free_length) {
  const Vec<3> a = base.direction.normalized();
  bending->hold_base(free_length, a / a.dot(axis));
  const double ratio = 1.0 / std::tan(opt.bevel_angle * M_PI / 180.0);
  bending->set_depth(depth, -base.bevel_side, ratio, base.position - entry);
}

void HapticNeedle::Impl::record_bending(bool bent) {
  Step& out = result;
  out.tip_deviation = bent ? bending->deflection(depth) : Vec<3>::Zero();
  out.tip += out.tip_deviation;
  out.tip_angle = bent ? std::atan(bending->slope(depth).norm()) * 180.0 / M_PI : 0.0;
  out.base_force = bent ? bending->base_force() : Vec<3>::Zero();
  out.base_moment = bent ? bending->base_moment() : Vec<3>::Zero();
}

const HapticNeedle::Step& HapticNeedle::step(const Vec<3>& tip, const Vec<3>& direction) {
  Impl& h = *impl_;
  if (h.opt.flexible)
    throw std::logic_error("HapticNeedle::step: a flexible needle steps by its base's pose");
  if (!tip.allFinite() || !(direction.norm() > 0.0) || !direction.allFinite())
    throw std::invalid_argument("HapticNeedle::step: the tip and a non-zero direction must be finite");
  h.axis = direction.normalized();
  if (!h.stepping) h.tip = tip, h.start(tip);
  h.pick_up(tip, h.axis.dot(tip - h.tip));
  h.solve(h.tissue);
  return h.result;
}

// The rows stay on the planned line (the first pose's axis), the tip on it at the needle's depth; the
// beam bends from the holder.
const HapticNeedle::Step& HapticNeedle::step(const BasePose& base) {
  Impl& h = *impl_;
  if (!h.opt.flexible) throw std::logic_error("HapticNeedle::step: a rigid needle steps by its tip");
  if (!base.position.allFinite() || !base.direction.allFinite() || !(base.direction.norm() > 0.0) ||
      !std::isfinite(base.length) || !base.bevel_side.allFinite())
    throw std::invalid_argument("HapticNeedle::step: the base's pose must be finite, its direction non-zero");
  const Vec<3> straight = base.position + base.length * base.direction.normalized();
  if (!h.stepping) {
    h.axis = base.direction.normalized(), h.entry = h.tip = straight;
    h.start(straight);
    h.make_bending();
  }
  if (!(base.direction.dot(h.axis) > 0.0))
    throw std::invalid_argument("HapticNeedle::step: the needle turned away from the planned line");
  const double free_length = h.axis.dot(h.entry - base.position);
  if (!(free_length >= 0.0)) throw std::invalid_argument("HapticNeedle::step: the holder is past the entry");
  const double travel = h.axis.dot(straight - h.tip);
  const bool on = h.pick_up(h.entry + (h.depth + travel) * h.axis, travel);
  if (on) h.bend(base, free_length);
  h.solve(on ? static_cast<TissueResponse&>(*h.bending) : h.tissue);
  h.record_bending(on && h.bending->depth() == h.depth);
  return h.result;
}

std::vector<PointConstraint<3>> HapticNeedle::constraints() const {
  const ShaftState& st = state();
  std::vector<PointConstraint<3>> rows;
  for (std::size_t j : st.active) rows.push_back(impl_->tissue.row(j, st.axial[j]));
  return rows;
}

}  // namespace vim::needle

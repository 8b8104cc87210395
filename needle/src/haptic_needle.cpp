// A needle at haptic rate in a condensed tissue region (vim/needle/haptic_needle.hpp): needle::Insertion
// and the registered friction law step it; the tissue behind needle::TissueResponse is the region's W.
// Per station j and model axis d the row c_{j,d} (the band mean of the shape functions along e_d, over
// the region's free DoFs, Dirichlet values as a constant h_{j,d}) is formed once, when the band is
// placed, with Y_{j,d} = W c_{j,d}; the blocks M_jk = [c_{j,d}·Y_{k,d'}] (3×3, model axes) and the
// probes' blocks P_pj = [π_{p,d}·Y_{j,d'}] then give every solve's Schur system in the current needle
// frame F:
//   S_(jr)(ks) = F_rᵀ M_jk F_s + δ κ_jr,  S μ = F_rᵀ(c_j·u0 + h_j) − g_jr,
// the force on the tissue at station j −F μ_j, and u(p) = π_p·u0 + h_p − Σ_j P_pj F μ_j. S is factorised
// once per step; the axial map of the law is the axial block of S⁻¹ (f_j = −μ_j,axial is affine in the
// axial values g_j,axial).
#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <vim/fem/condensed_region.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/insertion.hpp>
#include <vim/needle/needle_band.hpp>

namespace vim::needle {

using Term = fem::CondensedRegion::Term;
using Index = Eigen::Index;

namespace {

// The condensed region behind the tissue interface: the placed stations' rows, their Schur system in
// the current frame, and the last solve's multipliers.
class RegionTissue final : public TissueResponse {
 public:
  RegionTissue(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
               const fem::SolverOptions& solver, const NeedleBand& band, std::size_t capacity,
               const ShaftState& state);

  // Places station `placed()` centred at `at`, its band around the unit `axis`.
  void place(const Vec<3>& at, const Vec<3>& axis);
  std::size_t placed() const { return n_; }
  // A new pose: the frame of every row and the lateral value that holds each band on the needle axis.
  void set_pose(const Vec<3>& tip, const Eigen::Matrix3d& frame) {
    tip_ = tip, F_ = frame, factored_ = false;
  }
  // No station on the needle: the multipliers vanish.
  void clear();
  // The displacement along the needle axis that station j's rows hold in the last solve.
  double held_axial(std::size_t j) const;

  const std::vector<double>& solve(const std::vector<double>& axial) override;
  const AxialMap& axial_map() override;

  std::size_t slots() const { return region_->slots(); }
  // Of the last solve: the force on the tissue at station j (model axes), a probe's displacement.
  Vec<3> station_force(std::size_t j) const { return -nu_.segment<3>(3 * static_cast<Index>(j)); }
  Vec<3> probe_displacement(std::size_t p) const;
  PointConstraint<3> row(std::size_t j, double axial) const;

 private:
  void add_sample(const Vec<3>& x, double w);
  void form_y(Index j3);  // Y_j = W c_j, columns j3 … j3 + 2 of Y
  void factor();          // S of the active stations in frame F, factorised in place
  Vec<3> lateral(std::size_t j) const {
    return Vec<3>(F_.col(0).dot(tip_ - centre_[j]), F_.col(1).dot(tip_ - centre_[j]), 0.0);
  }

  std::optional<fem::CondensedRegion> region_;
  const Eigen::MatrixXd* W_ = nullptr;
  const Eigen::VectorXd* u0_ = nullptr;
  const std::vector<double>* E_ = nullptr;  // per model cell
  const ShaftState& state_;
  std::vector<std::array<std::vector<Term>, 3>> probe_rows_;
  Eigen::VectorXd pu0_;
  // the band template (frame coordinates, E = 1)
  std::vector<Vec<3>> band_offsets_;  // (l1, l2, axis) coordinates
  std::vector<double> band_weights_;
  std::vector<char> inside_;  // per template sample: inside the mesh at the band being placed
  Vec<3> band_compliance_ = Vec<3>::Zero();
  // the placed stations
  std::size_t n_ = 0;
  std::vector<Vec<3>> centre_, kappa_;
  std::vector<Eigen::Matrix3d> frame_;  // the frame its band was sampled in
  Eigen::MatrixXd Y_, M_, P_;           // slots × 3cap, 3cap × 3cap, 3probes × 3cap
  Eigen::VectorXd cu0_, nu_;            // 3cap: c_j·u0 + h_j; the last solve's F μ_j (model axes)
  // a station's row while it is formed
  Eigen::MatrixXd c_dense_;  // slots × 3
  std::array<std::vector<Term>, 3> sample_;
  std::vector<int> touched_;
  std::vector<char> is_touched_;
  // the step's Schur system over the active stations (3m rows, in the order of state.active)
  Vec<3> tip_ = Vec<3>::Zero();
  Eigen::Matrix3d F_ = Eigen::Matrix3d::Identity();
  bool factored_ = false;
  std::size_t factored_m_ = 0;
  Eigen::MatrixXd S_;
  Eigen::VectorXd b_, x_;  // F_rᵀ(c_j·u0 + h_j) − lateral; the solve's right-hand side and μ
  std::vector<double> forces_;
  AxialMap map_;
};

RegionTissue::RegionTissue(fem::ElasticModel<3>& model, const fem::Region<3>& region,
                           const std::vector<Vec<3>>& probes, const fem::SolverOptions& solver,
                           const NeedleBand& band, std::size_t cap, const ShaftState& state)
    : state_(state) {
  region_.emplace(model, region, probes, solver);
  W_ = &region_->inverse(), u0_ = &region_->u0(), E_ = &model.youngs_modulus();
  const PointConstraint<3> t = needle_band_constraint(Vec<3>::Zero(), Vec<3>::UnitZ(), band, Vec<3>::Zero(),
                                                      1.0, model.poisson_ratio());
  for (const auto& off : t.offsets) band_offsets_.push_back(t.axes.transpose() * off);
  band_weights_ = t.weights;
  inside_.assign(band_weights_.size(), 0);
  band_compliance_ = t.compliance;
  const std::size_t ns = region_->slots(), np = probes.size();
  const auto c3 = static_cast<Index>(3 * cap);
  Y_.resize(static_cast<Index>(ns), c3), M_.resize(c3, c3), P_.resize(static_cast<Index>(3 * np), c3);
  cu0_ = Eigen::VectorXd::Zero(c3), nu_ = Eigen::VectorXd::Zero(c3);
  centre_.resize(cap), kappa_.resize(cap), frame_.resize(cap);
  c_dense_ = Eigen::MatrixXd::Zero(static_cast<Index>(ns), 3);
  touched_.reserve(ns), is_touched_.assign(ns, 0);
  for (auto& terms : sample_) terms.reserve(256);
  S_.resize(c3, c3), b_.resize(c3), x_.resize(c3);
  forces_.assign(cap, 0.0);
  map_.K.resize(static_cast<Index>(cap), static_cast<Index>(cap)), map_.c.resize(static_cast<Index>(cap));
  pu0_.resize(static_cast<Index>(3 * np));
  probe_rows_.resize(np);
  for (std::size_t p = 0; p < np; ++p)
    for (unsigned d = 0; d < 3; ++d) {
      region_->terms(probes[p], 1.0, d, probe_rows_[p][d]);
      double v = 0.0;
      for (const Term& term : probe_rows_[p][d]) v += term.coef * (term.slot < 0 ? 1.0 : (*u0_)[term.slot]);
      pu0_[static_cast<Index>(3 * p + d)] = v;
    }
}

// Adds w·N(x) along the model axes to the columns of c_dense (their constants to c_j·u0).
void RegionTissue::add_sample(const Vec<3>& x, double w) {
  for (auto& terms : sample_) terms.clear();
  region_->terms(x, w, sample_);
  for (Index d = 0; d < 3; ++d)
    for (const Term& term : sample_[static_cast<std::size_t>(d)]) {
      if (term.slot < 0) {
        cu0_[static_cast<Index>(3 * n_) + d] += term.coef;
        continue;
      }
      if (!is_touched_[static_cast<std::size_t>(term.slot)]) {
        is_touched_[static_cast<std::size_t>(term.slot)] = 1;
        touched_.push_back(term.slot);
      }
      c_dense_(term.slot, d) += term.coef;
    }
}

// Y_j = W c_j over the touched slots, four columns of W at a time (Y_j is read and written once per four
// slots rather than once per slot).
void RegionTissue::form_y(Index j3) {
  const Index ns = Y_.rows();
  double* __restrict y0 = Y_.col(j3).data();
  double* __restrict y1 = Y_.col(j3 + 1).data();
  double* __restrict y2 = Y_.col(j3 + 2).data();
  std::fill(y0, y0 + ns, 0.0), std::fill(y1, y1 + ns, 0.0), std::fill(y2, y2 + ns, 0.0);
  const std::size_t nt = touched_.size();
  std::size_t t = 0;
  for (; t + 4 <= nt; t += 4) {
    const double* __restrict w0 = W_->col(touched_[t]).data();
    const double* __restrict w1 = W_->col(touched_[t + 1]).data();
    const double* __restrict w2 = W_->col(touched_[t + 2]).data();
    const double* __restrict w3 = W_->col(touched_[t + 3]).data();
    std::array<std::array<double, 4>, 3> a{};
    for (Index d = 0; d < 3; ++d)
      for (std::size_t i = 0; i < 4; ++i) a[static_cast<std::size_t>(d)][i] = c_dense_(touched_[t + i], d);
    for (Index r = 0; r < ns; ++r) {
      y0[r] += w0[r] * a[0][0] + w1[r] * a[0][1] + w2[r] * a[0][2] + w3[r] * a[0][3];
      y1[r] += w0[r] * a[1][0] + w1[r] * a[1][1] + w2[r] * a[1][2] + w3[r] * a[1][3];
      y2[r] += w0[r] * a[2][0] + w1[r] * a[2][1] + w2[r] * a[2][2] + w3[r] * a[2][3];
    }
  }
  for (; t < nt; ++t) Y_.middleCols<3>(j3).noalias() += W_->col(touched_[t]) * c_dense_.row(touched_[t]);
}

// As BandCoupling's stations: the samples inside the mesh, renormalised; the compliance of unit modulus
// divided by the mean modulus of the cells the samples fall in.
void RegionTissue::place(const Vec<3>& at, const Vec<3>& axis) {
  const Eigen::Matrix3d frame_j = needle_frame(axis);
  const auto j3 = static_cast<Index>(3 * n_);
  double inside = 0.0, e_sum = 0.0;
  int cells = 0;
  for (std::size_t q = 0; q < band_offsets_.size(); ++q) {
    const long c = region_->locate(at + frame_j * band_offsets_[q]);
    inside_[q] = c >= 0;
    if (c < 0) continue;
    inside += band_weights_[q];
    e_sum += (*E_)[static_cast<std::size_t>(c)];
    ++cells;
  }
  if (!(inside > 0.0)) throw std::invalid_argument("HapticNeedle: a station's band lies outside the mesh");
  cu0_.segment<3>(j3).setZero();
  for (std::size_t q = 0; q < band_offsets_.size(); ++q)
    if (inside_[q]) add_sample(at + frame_j * band_offsets_[q], band_weights_[q] / inside);
  // Y_j = W c_j over the touched slots; M_jk = c_j·Y_k; the probes' blocks; c_j·u0
  form_y(j3);
  for (std::size_t k = 0; k <= n_; ++k) {
    Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
    for (int s : touched_)
      b.noalias() += c_dense_.row(s).transpose() * Y_.block<1, 3>(s, static_cast<Index>(3 * k));
    M_.block<3, 3>(j3, static_cast<Index>(3 * k)) = b;
    M_.block<3, 3>(static_cast<Index>(3 * k), j3) = b.transpose();
  }
  for (int s : touched_) cu0_.segment<3>(j3) += c_dense_.row(s).transpose() * (*u0_)[s];
  for (std::size_t p = 0; p < probe_rows_.size(); ++p)
    for (std::size_t d = 0; d < 3; ++d) {
      Eigen::RowVector3d v = Eigen::RowVector3d::Zero();
      for (const Term& t : probe_rows_[p][d])
        if (t.slot >= 0) v += t.coef * Y_.block<1, 3>(t.slot, j3);
      P_.block<1, 3>(static_cast<Index>(3 * p + d), j3) = v;
    }
  for (int s : touched_) c_dense_.row(s).setZero(), is_touched_[static_cast<std::size_t>(s)] = 0;
  touched_.clear();
  centre_[n_] = at, frame_[n_] = frame_j;
  kappa_[n_] = band_compliance_ / (e_sum / cells);
  nu_.segment<3>(j3).setZero();
  ++n_;
}

void RegionTissue::clear() {
  nu_.setZero();
  std::fill(forces_.begin(), forces_.end(), 0.0);
}

double RegionTissue::held_axial(std::size_t j) const {
  Vec<3> v = cu0_.segment<3>(static_cast<Index>(3 * j));
  for (std::size_t k = 0; k < n_; ++k)
    v -= M_.block<3, 3>(static_cast<Index>(3 * j), static_cast<Index>(3 * k)) *
         nu_.segment<3>(static_cast<Index>(3 * k));
  return F_.col(2).dot(v);
}

void RegionTissue::factor() {
  const std::size_t m = state_.active.size();
  if (factored_ && factored_m_ == m) return;
  const auto m3 = static_cast<Index>(3 * m);
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = state_.active[i];
    const auto i3 = static_cast<Index>(3 * i), j3 = static_cast<Index>(3 * j);
    for (std::size_t l = 0; l <= i; ++l) {
      const auto l3 = static_cast<Index>(3 * l), k3 = static_cast<Index>(3 * state_.active[l]);
      S_.block<3, 3>(i3, l3).noalias() = F_.transpose() * M_.block<3, 3>(j3, k3) * F_;
    }
    for (Index r = 0; r < 3; ++r) S_(i3 + r, i3 + r) += kappa_[j][r];
    b_.segment<3>(i3).noalias() = F_.transpose() * cu0_.segment<3>(j3);
    b_.segment<3>(i3) -= lateral(j);
  }
  Eigen::Ref<Eigen::MatrixXd> s = S_.topLeftCorner(m3, m3);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(s);
  if (llt.info() != Eigen::Success)
    throw fem::DependentPointConstraints("HapticNeedle: the stations' rows are dependent (a rigid band)");
  factored_ = true, factored_m_ = m;
}

const std::vector<double>& RegionTissue::solve(const std::vector<double>& axial) {
  factor();
  const std::size_t m = state_.active.size();
  const auto m3 = static_cast<Index>(3 * m);
  auto x = x_.head(m3);
  x = b_.head(m3);
  for (std::size_t i = 0; i < m; ++i) x[static_cast<Index>(3 * i + 2)] -= axial[state_.active[i]];
  const auto L = S_.topLeftCorner(m3, m3).triangularView<Eigen::Lower>();
  L.solveInPlace(x);
  L.transpose().solveInPlace(x);
  std::fill(forces_.begin(), forces_.end(), 0.0);
  nu_.setZero();
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = state_.active[i];
    nu_.segment<3>(static_cast<Index>(3 * j)).noalias() = F_ * x.segment<3>(static_cast<Index>(3 * i));
    forces_[j] = -x[static_cast<Index>(3 * i + 2)];
  }
  return forces_;
}

// f_i = −μ_i,axial with S μ = b − g: K = the axial block of S⁻¹, c = −(S⁻¹ b)_axial.
const AxialMap& RegionTissue::axial_map() {
  factor();
  const std::size_t m = state_.active.size();
  const auto m3 = static_cast<Index>(3 * m);
  const auto L = S_.topLeftCorner(m3, m3).triangularView<Eigen::Lower>();
  auto x = x_.head(m3);
  for (std::size_t k = 0; k <= m; ++k) {
    if (k < m)
      x.setZero(), x[static_cast<Index>(3 * k + 2)] = 1.0;
    else
      x = b_.head(m3);
    L.solveInPlace(x);
    L.transpose().solveInPlace(x);
    for (std::size_t i = 0; i < m; ++i) {
      const double v = x[static_cast<Index>(3 * i + 2)];
      if (k < m)
        map_.K(static_cast<Index>(i), static_cast<Index>(k)) = v;
      else
        map_.c[static_cast<Index>(i)] = -v;
    }
  }
  return map_;
}

Vec<3> RegionTissue::probe_displacement(std::size_t p) const {
  Vec<3> u = pu0_.segment<3>(static_cast<Index>(3 * p));
  for (std::size_t j = 0; j < n_; ++j)
    u -= P_.block<3, 3>(static_cast<Index>(3 * p), static_cast<Index>(3 * j)) *
         nu_.segment<3>(static_cast<Index>(3 * j));
  return u;
}

PointConstraint<3> RegionTissue::row(std::size_t j, double axial) const {
  PointConstraint<3> p(centre_[j]);
  p.axes = F_;
  for (const Vec<3>& off : band_offsets_) p.offsets.push_back(frame_[j] * off);
  p.weights = band_weights_;
  p.compliance = kappa_[j];
  p.displacement = lateral(j) + Vec<3>(0.0, 0.0, axial);
  return p;
}

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
  if (!(o.spacing > 0.0) || !(o.radius > 0.0) || o.max_stations == 0)
    throw std::invalid_argument("HapticNeedle: radius and spacing must be > 0 and max_stations ≥ 1");
  return o;
}

}  // namespace

struct HapticNeedle::Impl {
  Impl(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
       const Options& o, const fem::SolverOptions& solver)
      : opt(checked(o)),
        stepping(stepping_options(o), stations(o)),
        tissue(model, region, probes, solver,
               station_band(o.radius, o.coupling_radius, o.element_size, o.spacing, model.degree()),
               o.max_stations, stepping.state()) {}
  Options opt;
  Insertion<3> stepping;
  RegionTissue tissue;
  bool started = false;
  Vec<3> tip = Vec<3>::Zero(), axis = Vec<3>::UnitZ();
  double depth = 0.0;  // the needle's travel along its axis
  Step result;

  // Places the bands of stations up to j on the current axis, at their arc length behind the tip.
  void place_up_to(std::size_t j) {
    while (tissue.placed() <= j && tissue.placed() < opt.max_stations) {
      const double s = (static_cast<double>(tissue.placed()) + 0.5) * opt.spacing;
      tissue.place(tip - (depth - s) * axis, axis);
    }
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
const ShaftState& HapticNeedle::state() const { return impl_->stepping.state(); }

const HapticNeedle::Step& HapticNeedle::step(const Vec<3>& tip, const Vec<3>& direction) {
  Impl& h = *impl_;
  if (!tip.allFinite() || !(direction.norm() > 0.0) || !direction.allFinite())
    throw std::invalid_argument("HapticNeedle::step: the tip and a non-zero direction must be finite");
  h.axis = direction.normalized();
  if (!h.started) h.started = true, h.tip = tip;
  const double travel = h.axis.dot(tip - h.tip);
  h.depth += travel;
  h.tip = tip;
  h.tissue.set_pose(tip, needle_frame(h.axis));
  // The stepping reads the tissue of a station before it joins: its band is placed then.
  h.stepping.pick_up(h.depth, travel, [&h](std::size_t j) {
    if (j >= h.opt.max_stations) return 0.0;
    h.place_up_to(j);
    return h.tissue.held_axial(j);
  });
  const ShaftState& state = h.stepping.state();
  Step& out = h.result;
  out.sweeps = 0, out.settled = true;
  if (state.active.empty()) {
    h.tissue.clear();
  } else {
    h.place_up_to(state.active.back());
    const FrictionStep fs = h.stepping.solve(h.tissue);
    out.sweeps = fs.sweeps, out.settled = fs.settled;
  }
  out.stations = state.active.size();
  out.station_force.resize(state.active.size());
  out.force.setZero();
  for (std::size_t i = 0; i < state.active.size(); ++i) {
    out.station_force[i] = h.tissue.station_force(state.active[i]);
    out.force -= out.station_force[i];
  }
  for (std::size_t p = 0; p < out.probe_displacement.size(); ++p)
    out.probe_displacement[p] = h.tissue.probe_displacement(p);
  return out;
}

std::vector<PointConstraint<3>> HapticNeedle::constraints() const {
  const ShaftState& state = impl_->stepping.state();
  std::vector<PointConstraint<3>> rows;
  for (std::size_t j : state.active) rows.push_back(impl_->tissue.row(j, state.axial[j]));
  return rows;
}

}  // namespace vim::needle

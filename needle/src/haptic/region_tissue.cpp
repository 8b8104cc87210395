// The condensed region behind the real-time needle (region_tissue.hpp).
#include "region_tissue.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <vim/needle/tip_bearing.hpp>

namespace vim::needle::haptic {

RegionTissue::RegionTissue(fem::ElasticModel<3>& model, const fem::Region<3>& region,
                           const std::vector<Vec<3>>& probes, const fem::SolverOptions& solver,
                           const NeedleBand& band, const Pattern& disk, std::size_t cap)
    : cap_(cap), disk_(disk) {
  region_.emplace(model, region, probes, solver);
  W_ = &region_->inverse(), u0_ = &region_->u0(), E_ = &model.youngs_modulus();
  const PointConstraint<3> t = needle_band_constraint(Vec<3>::Zero(), Vec<3>::UnitZ(), band, Vec<3>::Zero(),
                                                      1.0, model.poisson_ratio());
  band_ = pattern_of(t);
  inside_.assign(std::max(band_.weights.size(), disk_.weights.size()), 0);
  band_compliance_ = t.compliance;
  const std::size_t ns = region_->slots(), np = probes.size();
  const auto c3 = static_cast<Index>(3 * (cap + 1));
  Y_.resize(static_cast<Index>(ns), c3), M_.resize(c3, c3), P_.resize(static_cast<Index>(3 * np), c3);
  cu0_ = Eigen::VectorXd::Zero(c3), nu_ = Eigen::VectorXd::Zero(c3);
  centre_.resize(cap + 1), kappa_.resize(cap + 1), frame_.resize(cap + 1);
  deflection_.assign(cap + 1, Vec<3>::Zero());
  c_dense_ = Eigen::MatrixXd::Zero(static_cast<Index>(ns), 3);
  touched_.reserve(ns), is_touched_.assign(ns, 0);
  for (auto& terms : sample_) terms.reserve(256);
  S_.resize(c3, c3), b_.resize(c3), x_.resize(c3);
  map_.K.resize(static_cast<Index>(cap + 1), static_cast<Index>(cap + 1));
  map_.c.resize(static_cast<Index>(cap + 1));
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

void RegionTissue::attach(const ShaftState& state, std::size_t n_points) {
  state_ = &state;
  forces_.assign(n_points, 0.0);
}

// Adds w·N(x) along the model axes to the columns of c_dense (their constants to c_k·u0).
void RegionTissue::add_sample(Index k3, const Vec<3>& x, double w) {
  for (auto& terms : sample_) terms.clear();
  region_->terms(x, w, sample_);
  for (Index d = 0; d < 3; ++d)
    for (const Term& term : sample_[static_cast<std::size_t>(d)]) {
      if (term.slot < 0) {
        cu0_[k3 + d] += term.coef;
        continue;
      }
      if (!is_touched_[static_cast<std::size_t>(term.slot)]) {
        is_touched_[static_cast<std::size_t>(term.slot)] = 1;
        touched_.push_back(term.slot);
      }
      c_dense_(term.slot, d) += term.coef;
    }
}

// Y_k = W c_k over the touched slots, four columns of W at a time (Y_k is read and written once per four
// slots rather than once per slot).
void RegionTissue::form_y(Index k3) {
  const Index ns = Y_.rows();
  double* __restrict y0 = Y_.col(k3).data();
  double* __restrict y1 = Y_.col(k3 + 1).data();
  double* __restrict y2 = Y_.col(k3 + 2).data();
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
  for (; t < nt; ++t) Y_.middleCols<3>(k3).noalias() += W_->col(touched_[t]) * c_dense_.row(touched_[t]);
}

RegionTissue::Inside RegionTissue::locate(const Vec<3>& at, const Eigen::Matrix3d& frame,
                                          const Pattern& pattern) {
  Inside in;
  double e_sum = 0.0;
  for (std::size_t q = 0; q < pattern.offsets.size(); ++q) {
    const long c = region_->locate(at + frame * pattern.offsets[q]);
    inside_[q] = c >= 0;
    if (c < 0) continue;
    in.weight += pattern.weights[q];
    e_sum += (*E_)[static_cast<std::size_t>(c)];
    ++in.count;
  }
  if (in.count > 0) in.modulus = e_sum / static_cast<double>(in.count);
  return in;
}

// As the CLI's rows: the samples inside the mesh, renormalised.
void RegionTissue::form(std::size_t k, const Vec<3>& at, const Eigen::Matrix3d& frame, const Pattern& pattern,
                        double weight) {
  const auto k3 = static_cast<Index>(3 * k);
  cu0_.segment<3>(k3).setZero();
  for (std::size_t q = 0; q < pattern.offsets.size(); ++q)
    if (inside_[q]) add_sample(k3, at + frame * pattern.offsets[q], pattern.weights[q] / weight);
  // Y_k = W c_k over the touched slots; M_kl = c_k·Y_l for every formed slot l; the probes' blocks; c_k·u0
  form_y(k3);
  for (std::size_t l = 0; l <= cap_; ++l) {
    if (l != k && !formed(l)) continue;
    Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
    for (int s : touched_)
      b.noalias() += c_dense_.row(s).transpose() * Y_.block<1, 3>(s, static_cast<Index>(3 * l));
    M_.block<3, 3>(k3, static_cast<Index>(3 * l)) = b;
    M_.block<3, 3>(static_cast<Index>(3 * l), k3) = b.transpose();
  }
  for (int s : touched_) cu0_.segment<3>(k3) += c_dense_.row(s).transpose() * (*u0_)[s];
  for (std::size_t p = 0; p < probe_rows_.size(); ++p)
    for (std::size_t d = 0; d < 3; ++d) {
      Eigen::RowVector3d v = Eigen::RowVector3d::Zero();
      for (const Term& t : probe_rows_[p][d])
        if (t.slot >= 0) v += t.coef * Y_.block<1, 3>(t.slot, k3);
      P_.block<1, 3>(static_cast<Index>(3 * p + d), k3) = v;
    }
  for (int s : touched_) c_dense_.row(s).setZero(), is_touched_[static_cast<std::size_t>(s)] = 0;
  touched_.clear();
  centre_[k] = at, frame_[k] = frame;
  nu_.segment<3>(k3).setZero();
}

// As BandCoupling's stations: the compliance of unit modulus divided by the mean modulus of the cells
// the samples fall in.
void RegionTissue::place(const Vec<3>& at, const Vec<3>& axis) {
  const Eigen::Matrix3d frame = needle_frame(axis);
  const Inside in = locate(at, frame, band_);
  if (!(in.weight > 0.0)) throw std::invalid_argument("HapticNeedle: a station's band lies outside the mesh");
  form(n_, at, frame, band_, in.weight);
  kappa_[n_] = band_compliance_ / in.modulus;
  ++n_;
}

// As BandCoupling's tip rows: a disk with fewer than half of its samples in the mesh is not in the tissue.
void RegionTissue::place_tip(std::size_t index, const Vec<3>& at, const Vec<3>& axis, double compliance) {
  const Eigen::Matrix3d frame = needle_frame(axis);
  const Inside in = locate(at, frame, disk_);
  if (!tip_disk_in_tissue(in.count, disk_.offsets.size()))
    throw std::invalid_argument("HapticNeedle: the tip's disk lies outside the mesh");
  tip_ = kNone;  // its old blocks are not read while it is formed
  form(cap_, at, frame, disk_, in.weight);
  kappa_[cap_] = Vec<3>(0.0, 0.0, compliance / in.modulus);
  tip_ = index;
}

void RegionTissue::clear() {
  nu_.setZero();
  std::fill(forces_.begin(), forces_.end(), 0.0);
}

double RegionTissue::held_axial(std::size_t j) const {
  Vec<3> v = cu0_.segment<3>(static_cast<Index>(3 * j));
  for (std::size_t k = 0; k <= cap_; ++k)
    if (formed(k))
      v -= M_.block<3, 3>(static_cast<Index>(3 * j), static_cast<Index>(3 * k)) *
           nu_.segment<3>(static_cast<Index>(3 * k));
  return F_.col(2).dot(v);
}

Index RegionTissue::rows() const { return static_cast<Index>(3 * ms_ + (factored_m_ - ms_)); }

void RegionTissue::factor() {
  const std::vector<std::size_t>& active = state_->active;
  const std::size_t m = active.size();
  if (factored_ && factored_m_ == m) return set_rhs();
  factored_m_ = m;
  ms_ = m > 0 && active.back() >= cap_ ? m - 1 : m;
  for (std::size_t i = 0; i < ms_; ++i) {
    const std::size_t j = active[i];
    const auto i3 = static_cast<Index>(3 * i), j3 = static_cast<Index>(3 * j);
    for (std::size_t l = 0; l <= i; ++l) {
      const auto l3 = static_cast<Index>(3 * l), k3 = static_cast<Index>(3 * active[l]);
      S_.block<3, 3>(i3, l3).noalias() = F_.transpose() * M_.block<3, 3>(j3, k3) * F_;
    }
    for (Index r = 0; r < 3; ++r) S_(i3 + r, i3 + r) += kappa_[j][r];
  }
  if (ms_ < m) {  // the tip's disk: its axial row
    const auto t = static_cast<Index>(3 * ms_), c3 = static_cast<Index>(3 * cap_);
    const Vec<3> a = F_.col(2);
    for (std::size_t l = 0; l < ms_; ++l)
      S_.block<1, 3>(t, static_cast<Index>(3 * l)).noalias() =
          a.transpose() * M_.block<3, 3>(c3, static_cast<Index>(3 * active[l])) * F_;
    S_(t, t) = a.dot(M_.block<3, 3>(c3, c3) * a) + kappa_[cap_][2];
  }
  const Index n = rows();
  Eigen::Ref<Eigen::MatrixXd> s = S_.topLeftCorner(n, n);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(s);
  if (llt.info() != Eigen::Success)
    throw fem::DependentPointConstraints("HapticNeedle: the stations' rows are dependent (a rigid band)");
  factored_ = true, rhs_set_ = false;
  set_rhs();
}

// b of the active points: F_rᵀ(c_j·u0 + h_j) − the lateral value (a deflection moves only this).
void RegionTissue::set_rhs() {
  if (rhs_set_) return;
  const std::vector<std::size_t>& active = state_->active;
  for (std::size_t i = 0; i < ms_; ++i) {
    const auto i3 = static_cast<Index>(3 * i), j3 = static_cast<Index>(3 * active[i]);
    b_.segment<3>(i3).noalias() = F_.transpose() * cu0_.segment<3>(j3);
    b_.segment<3>(i3) -= lateral(active[i]);
  }
  if (ms_ < factored_m_)
    b_[static_cast<Index>(3 * ms_)] = F_.col(2).dot(cu0_.segment<3>(static_cast<Index>(3 * cap_)));
  rhs_set_ = true;
}

const std::vector<double>& RegionTissue::solve(const std::vector<double>& axial) {
  factor();
  const std::vector<std::size_t>& active = state_->active;
  const Index n = rows();
  auto x = x_.head(n);
  x = b_.head(n);
  for (std::size_t i = 0; i < active.size(); ++i) x[axial_row(i)] -= axial[active[i]];
  const auto L = S_.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  L.solveInPlace(x);
  L.transpose().solveInPlace(x);
  std::fill(forces_.begin(), forces_.end(), 0.0);
  nu_.setZero();
  for (std::size_t i = 0; i < ms_; ++i) {
    const std::size_t j = active[i];
    nu_.segment<3>(static_cast<Index>(3 * j)).noalias() = F_ * x.segment<3>(static_cast<Index>(3 * i));
    forces_[j] = -x[static_cast<Index>(3 * i + 2)];
  }
  if (ms_ < active.size()) {
    nu_.segment<3>(static_cast<Index>(3 * cap_)) = F_.col(2) * x[n - 1];
    forces_[active.back()] = -x[n - 1];
  }
  return forces_;
}

// f_i = −μ_i,axial with S μ = b − g: K = the axial block of S⁻¹, c = −(S⁻¹ b)_axial.
const AxialMap& RegionTissue::axial_map() {
  factor();
  const std::size_t m = state_->active.size();
  const Index n = rows();
  const auto L = S_.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  auto x = x_.head(n);
  for (std::size_t k = 0; k <= m; ++k) {
    if (k < m)
      x.setZero(), x[axial_row(k)] = 1.0;
    else
      x = b_.head(n);
    L.solveInPlace(x);
    L.transpose().solveInPlace(x);
    for (std::size_t i = 0; i < m; ++i) {
      const double v = x[axial_row(i)];
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
  for (std::size_t k = 0; k <= cap_; ++k)
    if (formed(k))
      u -= P_.block<3, 3>(static_cast<Index>(3 * p), static_cast<Index>(3 * k)) *
           nu_.segment<3>(static_cast<Index>(3 * k));
  return u;
}

PointConstraint<3> RegionTissue::row(std::size_t j, double axial) const {
  const std::size_t k = slot(j);
  const Pattern& pattern = k < cap_ ? band_ : disk_;
  PointConstraint<3> p(centre_[k]);
  p.axes = F_;
  for (const Vec<3>& off : pattern.offsets) p.offsets.push_back(frame_[k] * off);
  p.weights = pattern.weights;
  p.compliance = kappa_[k];
  if (k < cap_) {
    p.displacement = lateral(k) + Vec<3>(0.0, 0.0, axial);
  } else {
    p.components = {{false, false, true}};
    p.displacement = Vec<3>(0.0, 0.0, axial);
  }
  return p;
}

}  // namespace vim::needle::haptic

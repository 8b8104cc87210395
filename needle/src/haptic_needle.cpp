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
// axial values g_j,axial). The tip's disk (the tip bearing, when the law cuts) is one more slot, formed
// like a station when the tip starts pressing a disk, of which only the axial row a = F_2 enters S:
//   S_(tip)(ks) = aᵀ M_tk F_s,  S_(tip)(tip) = aᵀ M_tt a + κ_tip,  b_tip = a·(c_t·u0 + h_t).
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
#include <vim/needle/tip_bearing.hpp>

namespace vim::needle {

using Term = fem::CondensedRegion::Term;
using Index = Eigen::Index;

namespace {

// A row's sample pattern in frame coordinates (l1, l2, axis) with its weights.
struct Pattern {
  std::vector<Vec<3>> offsets;
  std::vector<double> weights;
};

Pattern pattern_of(const PointConstraint<3>& row) {
  Pattern p;
  for (const auto& off : row.offsets) p.offsets.push_back(row.axes.transpose() * off);
  p.weights = row.weights;
  return p;
}

// The condensed region behind the tissue interface: the placed stations' rows and the tip's disk (slot
// `cap`, axial only), their Schur system in the current frame, and the last solve's multipliers.
class RegionTissue final : public TissueResponse {
 public:
  RegionTissue(fem::ElasticModel<3>& model, const fem::Region<3>& region, const std::vector<Vec<3>>& probes,
               const fem::SolverOptions& solver, const NeedleBand& band, const Pattern& disk,
               std::size_t cap);

  // The stepping whose active points the solves take (n_points: stations, then the tip's disks).
  void attach(const ShaftState& state, std::size_t n_points);
  // Places station `placed()` centred at `at`, its band around the unit `axis`.
  void place(const Vec<3>& at, const Vec<3>& axis);
  std::size_t placed() const { return n_; }
  // Places the tip's disk, point `index` of the stepping, centred at `at` normal to the unit `axis`;
  // `compliance`: κ_tip of unit modulus (divided by the mean modulus of the cells its samples fall in).
  void place_tip(std::size_t index, const Vec<3>& at, const Vec<3>& axis, double compliance);
  std::size_t tip_index() const { return tip_; }
  // A new pose: the frame of every row and the lateral value that holds each band on the needle axis.
  void set_pose(const Vec<3>& tip, const Eigen::Matrix3d& frame) {
    tip_at_ = tip, F_ = frame, factored_ = false;
  }
  // No point on the needle: the multipliers vanish.
  void clear();
  // The displacement along the needle axis that station j's rows hold in the last solve.
  double held_axial(std::size_t j) const;

  const std::vector<double>& solve(const std::vector<double>& axial) override;
  const AxialMap& axial_map() override;

  std::size_t slots() const { return region_->slots(); }
  // Of the last solve: the force on the tissue at point j (model axes), a probe's displacement.
  Vec<3> point_force(std::size_t j) const { return -nu_.segment<3>(3 * static_cast<Index>(slot(j))); }
  Vec<3> probe_displacement(std::size_t p) const;
  PointConstraint<3> row(std::size_t j, double axial) const;

 private:
  std::size_t slot(std::size_t j) const { return j < cap_ ? j : cap_; }
  // The samples at + frame·offsets in the mesh: their weight, the mean modulus of their cells, and how
  // many (inside_ marks them).
  struct Inside {
    double weight = 0.0, modulus = 0.0;
    std::size_t count = 0;
  };
  Inside locate(const Vec<3>& at, const Eigen::Matrix3d& frame, const Pattern& pattern);
  // Forms slot k's rows of the samples inside_ marks: c_k, Y_k = W c_k, its blocks of M with every
  // placed slot, its probes' blocks and c_k·u0.
  void form(std::size_t k, const Vec<3>& at, const Eigen::Matrix3d& frame, const Pattern& pattern,
            double weight);
  void add_sample(Index k3, const Vec<3>& x, double w);
  void form_y(Index k3);  // Y_k = W c_k, columns k3 … k3 + 2 of Y
  bool formed(std::size_t k) const { return k < n_ || (k == cap_ && tip_ != kNone); }
  void factor();  // S of the active points in frame F, factorised in place
  Index rows() const;
  Index axial_row(std::size_t i) const {
    return i < ms_ ? static_cast<Index>(3 * i + 2) : static_cast<Index>(3 * ms_);
  }
  Vec<3> lateral(std::size_t j) const {
    return Vec<3>(F_.col(0).dot(tip_at_ - centre_[j]), F_.col(1).dot(tip_at_ - centre_[j]), 0.0);
  }

  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::optional<fem::CondensedRegion> region_;
  const Eigen::MatrixXd* W_ = nullptr;
  const Eigen::VectorXd* u0_ = nullptr;
  const std::vector<double>* E_ = nullptr;  // per model cell
  const ShaftState* state_ = nullptr;
  std::size_t cap_ = 0;
  std::vector<std::array<std::vector<Term>, 3>> probe_rows_;
  Eigen::VectorXd pu0_;
  Pattern band_, disk_;                      // the band's and the tip disk's samples
  std::vector<char> inside_;                 // per sample: inside the mesh at the row being placed
  Vec<3> band_compliance_ = Vec<3>::Zero();  // of unit modulus
  // the placed stations (slots 0 … n_ − 1) and the tip's disk (slot cap_, point tip_)
  std::size_t n_ = 0, tip_ = kNone;
  std::vector<Vec<3>> centre_, kappa_;
  std::vector<Eigen::Matrix3d> frame_;  // the frame its samples were placed in
  Eigen::MatrixXd Y_, M_, P_;  // slots × 3(cap + 1), 3(cap + 1) × 3(cap + 1), 3probes × 3(cap + 1)
  Eigen::VectorXd cu0_, nu_;   // 3(cap + 1): c_k·u0 + h_k; the last solve's F μ_k (model axes)
  // a row while it is formed
  Eigen::MatrixXd c_dense_;  // slots × 3
  std::array<std::vector<Term>, 3> sample_;
  std::vector<int> touched_;
  std::vector<char> is_touched_;
  // the step's Schur system over the active points (3 rows per station, 1 for the tip; state order)
  Vec<3> tip_at_ = Vec<3>::Zero();
  Eigen::Matrix3d F_ = Eigen::Matrix3d::Identity();
  bool factored_ = false;
  std::size_t factored_m_ = 0, ms_ = 0;  // active points, of which stations
  Eigen::MatrixXd S_;
  Eigen::VectorXd b_, x_;  // F_rᵀ(c_j·u0 + h_j) − lateral; the solve's right-hand side and μ
  std::vector<double> forces_;
  AxialMap map_;
};

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
  if (factored_ && factored_m_ == m) return;
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
    b_.segment<3>(i3).noalias() = F_.transpose() * cu0_.segment<3>(j3);
    b_.segment<3>(i3) -= lateral(j);
  }
  if (ms_ < m) {  // the tip's disk: its axial row
    const auto t = static_cast<Index>(3 * ms_), c3 = static_cast<Index>(3 * cap_);
    const Vec<3> a = F_.col(2);
    for (std::size_t l = 0; l < ms_; ++l)
      S_.block<1, 3>(t, static_cast<Index>(3 * l)).noalias() =
          a.transpose() * M_.block<3, 3>(c3, static_cast<Index>(3 * active[l])) * F_;
    S_(t, t) = a.dot(M_.block<3, 3>(c3, c3) * a) + kappa_[cap_][2];
    b_[t] = a.dot(cu0_.segment<3>(c3));
  }
  const Index n = rows();
  Eigen::Ref<Eigen::MatrixXd> s = S_.topLeftCorner(n, n);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(s);
  if (llt.info() != Eigen::Success)
    throw fem::DependentPointConstraints("HapticNeedle: the stations' rows are dependent (a rigid band)");
  factored_ = true;
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

const HapticNeedle::Step& HapticNeedle::step(const Vec<3>& tip, const Vec<3>& direction) {
  Impl& h = *impl_;
  if (!tip.allFinite() || !(direction.norm() > 0.0) || !direction.allFinite())
    throw std::invalid_argument("HapticNeedle::step: the tip and a non-zero direction must be finite");
  h.axis = direction.normalized();
  if (!h.stepping) h.tip = tip, h.start(tip);
  const double travel = h.axis.dot(tip - h.tip);
  h.depth += travel;
  h.tip = tip;
  h.tissue.set_pose(tip, needle_frame(h.axis));
  // The stepping reads the tissue of a station before it joins: its band is placed then.
  h.stepping->pick_up(h.depth, travel, [&h](std::size_t j) {
    if (j >= h.opt.max_stations) return 0.0;
    h.place_up_to(j);
    return h.tissue.held_axial(j);
  });
  const ShaftState& state = h.stepping->state();
  Step& out = h.result;
  out.sweeps = 0, out.settled = true;
  if (state.active.empty()) {
    h.tissue.clear();
  } else {
    if (state.tip < h.opt.max_stations) h.place_up_to(state.tip);
    h.place_tip();
    // A puncture joins the tissue it cuts within the solve: every station the tip may reach is placed.
    const double cut = h.depth - h.opt.friction.cutting_distance;
    if (h.tissue.tip_index() < h.stepping->n_points() && cut > 0.0)
      h.place_up_to(static_cast<std::size_t>(cut / h.opt.spacing));
    const FrictionStep fs = h.stepping->solve(h.tissue);
    out.sweeps = fs.sweeps, out.settled = fs.settled;
  }
  // After the solve: the active set may have grown (the tissue a puncture cut joins).
  out.stations = 0;
  out.station_force.clear();
  out.tip_force.setZero();
  for (std::size_t j : state.active) {
    if (j < h.opt.max_stations)
      out.station_force.push_back(h.tissue.point_force(j)), ++out.stations;
    else
      out.tip_force = h.tissue.point_force(j);
  }
  out.tip_cutting = state.tip_cutting;
  out.force = -out.tip_force;
  for (const Vec<3>& f : out.station_force) out.force -= f;
  for (std::size_t p = 0; p < out.probe_displacement.size(); ++p)
    out.probe_displacement[p] = h.tissue.probe_displacement(p);
  return out;
}

std::vector<PointConstraint<3>> HapticNeedle::constraints() const {
  const ShaftState& st = state();
  std::vector<PointConstraint<3>> rows;
  for (std::size_t j : st.active) rows.push_back(impl_->tissue.row(j, st.axial[j]));
  return rows;
}

}  // namespace vim::needle

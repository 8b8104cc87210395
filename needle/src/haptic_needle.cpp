// A needle at haptic rate in a condensed tissue region (vim/needle/haptic_needle.hpp). Per station j and
// model axis d the row c_{j,d} (the band mean of the shape functions along e_d, over the region's free
// DoFs, Dirichlet values as a constant h_{j,d}) is formed once, when the station joins, with
// Y_{j,d} = W c_{j,d}; the blocks M_jk = [c_{j,d}·Y_{k,d'}] (3×3, model axes) and the probes' blocks
// P_pj = [π_{p,d}·Y_{j,d'}] then give every step's Schur system in the current needle frame F:
//   S_(jr)(ks) = F_rᵀ M_jk F_s + δ κ_jr,  r_(jr) = F_rᵀ(c_j·u0 + h_j) − g_jr,
// the force on the tissue at station j −F μ_j, and u(p) = π_p·u0 + h_p − Σ_j P_pj F μ_j.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <vim/fem/condensed_region.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/needle_band.hpp>

namespace vim::needle {

using Term = fem::CondensedRegion::Term;

struct HapticNeedle::Impl {
  Options opt;
  // ---- the region: W = K⁻¹ and u0 on its slots (fem) ----
  std::optional<fem::CondensedRegion> region;
  const Eigen::MatrixXd* W = nullptr;
  const Eigen::VectorXd* u0 = nullptr;
  const std::vector<double>* E = nullptr;  // per model cell
  // ---- probes (model axes) ----
  std::vector<std::array<std::vector<Term>, 3>> probe_rows;
  Eigen::VectorXd pu0;
  // ---- the band template (frame coordinates, E = 1) and the stations ----
  std::vector<Vec<3>> band_offsets;  // (l1, l2, axis) coordinates
  std::vector<double> band_weights;
  Vec<3> band_compliance = Vec<3>::Zero();
  std::size_t n = 0;                   // stations
  std::vector<Vec<3>> centre;          // per station
  std::vector<Eigen::Matrix3d> frame;  // the frame its band was sampled in
  Eigen::MatrixXd Y;                   // slots × 3·cap
  Eigen::MatrixXd M;                   // 3·cap × 3·cap
  Eigen::MatrixXd P;                   // 3·probes × 3·cap
  Eigen::VectorXd cu0;                 // 3·cap: c_j·u0 + h_j (model axes)
  std::vector<Vec<3>> kappa;           // per station (frame rows)
  std::vector<double> base, travel0, slip, g_axial, sign;
  std::vector<bool> sliding;
  // ---- workspace of a station's row and of a step ----
  Eigen::MatrixXd c_dense;   // slots × 3
  std::vector<Term> sample;  // the terms of one sample
  std::vector<int> touched;
  std::vector<char> is_touched;
  Eigen::MatrixXd S, L;
  Eigen::VectorXd r, mu, nu, rhs;  // nu: μ in model axes, per station
  std::vector<int> free_rows;
  // ---- the pose ----
  bool started = false;
  Vec<3> prev_tip = Vec<3>::Zero(), track_end = Vec<3>::Zero();
  double tau = 0.0;  // the needle's axial travel
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  Step result;

  void add_sample(const Vec<3>& x, double w, std::size_t d);
  void join(const Vec<3>& at, const Vec<3>& axis);
  void solve_set();
  void assemble(const Vec<3>& tip);
  double axial_of(std::size_t j) const;  // the tissue's axial value at station j (F axis)
  // The value that moves station j with the needle: its value at joining plus the travel since, less
  // its slip.
  double stick_value(std::size_t j) const {
    return sliding[j] ? g_axial[j] : base[j] + tau - travel0[j] - slip[j];
  }
};

HapticNeedle::HapticNeedle(fem::ElasticModel<3>& model, const fem::Region<3>& region,
                           const std::vector<Vec<3>>& probes, const Options& o,
                           const fem::SolverOptions& solver)
    : impl_(std::make_unique<Impl>()) {
  Impl& h = *impl_;
  h.opt = o;
  if (!(o.spacing > 0.0) || o.max_sweeps < 1 || o.max_stations == 0 || !(o.max_shear_per_length > 0.0))
    throw std::invalid_argument(
        "HapticNeedle: spacing, max_shear_per_length > 0, max_sweeps, max_stations ≥ 1");
  h.region.emplace(model, region, probes, solver);
  h.W = &h.region->inverse();
  h.u0 = &h.region->u0();
  h.E = &model.youngs_modulus();
  // the band template: frame coordinates, unit modulus
  const NeedleBand band{o.radius, o.coupling_radius, o.spacing};
  const PointConstraint<3> t = needle_band_constraint(Vec<3>::Zero(), Vec<3>::UnitZ(), band, Vec<3>::Zero(),
                                                      1.0, model.poisson_ratio());
  for (const auto& off : t.offsets) h.band_offsets.push_back(t.axes.transpose() * off);
  h.band_weights = t.weights;
  h.band_compliance = t.compliance;
  const std::size_t cap = o.max_stations, ns = h.region->slots(), np = probes.size();
  const auto c3 = static_cast<Eigen::Index>(3 * cap);
  h.Y.resize(static_cast<Eigen::Index>(ns), c3);
  h.M.resize(c3, c3);
  h.P.resize(static_cast<Eigen::Index>(3 * np), c3);
  h.cu0.resize(c3);
  h.centre.resize(cap), h.frame.resize(cap), h.kappa.resize(cap);
  h.base.resize(cap), h.travel0.resize(cap), h.slip.resize(cap), h.g_axial.resize(cap), h.sign.resize(cap);
  h.sliding.resize(cap);
  h.c_dense = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(ns), 3);
  h.touched.reserve(ns), h.is_touched.assign(ns, 0);
  h.sample.reserve(64);
  h.S.resize(c3, c3), h.L.resize(c3, c3), h.r.resize(c3), h.mu = Eigen::VectorXd::Zero(c3), h.rhs.resize(c3);
  h.nu = Eigen::VectorXd::Zero(c3);
  h.free_rows.reserve(3 * cap);
  // probes: their rows along the model axes
  h.pu0.resize(static_cast<Eigen::Index>(3 * np));
  h.probe_rows.resize(np);
  for (std::size_t p = 0; p < np; ++p)
    for (int d = 0; d < 3; ++d) {
      h.region->terms(probes[p], 1.0, static_cast<unsigned>(d), h.probe_rows[p][d]);
      double v = 0.0;
      for (const Term& term : h.probe_rows[p][d]) v += term.coef * (term.slot < 0 ? 1.0 : (*h.u0)[term.slot]);
      h.pu0[static_cast<Eigen::Index>(3 * p + d)] = v;
    }
  h.result.station_force.reserve(cap), h.result.sliding.reserve(cap);
  h.result.probe_displacement.resize(np);
  for (std::size_t p = 0; p < np; ++p) h.result.probe_displacement[p] = h.pu0.segment<3>(3 * p);
}

HapticNeedle::~HapticNeedle() = default;
HapticNeedle::HapticNeedle(HapticNeedle&&) noexcept = default;

std::size_t HapticNeedle::region_dofs() const { return impl_->region->slots(); }

// Adds w·N(x) along model axis `d` to column d of c_dense (its constant to c_j·u0).
void HapticNeedle::Impl::add_sample(const Vec<3>& x, double w, std::size_t d) {
  sample.clear();
  region->terms(x, w, static_cast<unsigned>(d), sample);
  for (const Term& term : sample) {
    if (term.slot < 0) {
      cu0[static_cast<Eigen::Index>(3 * n + d)] += term.coef;
    } else {
      if (!is_touched[static_cast<std::size_t>(term.slot)]) {
        is_touched[static_cast<std::size_t>(term.slot)] = 1;
        touched.push_back(term.slot);
      }
      c_dense(term.slot, static_cast<Eigen::Index>(d)) += term.coef;
    }
  }
}

// Station n joins, centred at `at`, its band sampled around `axis`.
void HapticNeedle::Impl::join(const Vec<3>& at, const Vec<3>& axis) {
  const Eigen::Matrix3d frame_j = needle_frame(axis);
  const auto j3 = static_cast<Eigen::Index>(3 * n);
  double inside = 0.0, e_sum = 0.0;
  int cells = 0;
  for (std::size_t q = 0; q < band_offsets.size(); ++q) {
    const long c = region->locate(at + frame_j * band_offsets[q]);
    if (c < 0) continue;
    inside += band_weights[q];
    e_sum += (*E)[static_cast<std::size_t>(c)];
    ++cells;
  }
  if (!(inside > 0.0)) throw std::invalid_argument("HapticNeedle: a station's band lies outside the mesh");
  cu0.segment<3>(j3).setZero();
  for (std::size_t q = 0; q < band_offsets.size(); ++q) {
    const Vec<3> x = at + frame_j * band_offsets[q];
    if (region->locate(x) < 0) continue;
    for (std::size_t d = 0; d < 3; ++d) add_sample(x, band_weights[q] / inside, d);
  }
  // Y_j = W c_j over the touched slots; M_jk = c_j·Y_k; the probes' blocks; c_j·u0
  Y.middleCols<3>(j3).setZero();
  for (int s : touched) Y.middleCols<3>(j3).noalias() += W->col(s) * c_dense.row(s);
  for (std::size_t k = 0; k <= n; ++k) {
    Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
    for (int s : touched)
      b.noalias() += c_dense.row(s).transpose() * Y.block<1, 3>(s, static_cast<Eigen::Index>(3 * k));
    M.block<3, 3>(j3, static_cast<Eigen::Index>(3 * k)) = b;
    M.block<3, 3>(static_cast<Eigen::Index>(3 * k), j3) = b.transpose();
  }
  for (int s : touched) cu0.segment<3>(j3) += c_dense.row(s).transpose() * (*u0)[s];
  for (std::size_t p = 0; p < probe_rows.size(); ++p)
    for (int d = 0; d < 3; ++d) {
      Eigen::RowVector3d v = Eigen::RowVector3d::Zero();
      for (const Term& t : probe_rows[p][static_cast<std::size_t>(d)])
        if (t.slot >= 0) v += t.coef * Y.block<1, 3>(t.slot, j3);
      P.block<1, 3>(static_cast<Eigen::Index>(3 * p + d), j3) = v;
    }
  for (int s : touched) c_dense.row(s).setZero(), is_touched[static_cast<std::size_t>(s)] = 0;
  touched.clear();
  centre[n] = at, frame[n] = frame_j;
  kappa[n] = band_compliance / (e_sum / cells);
  mu.segment<3>(j3).setZero(), nu.segment<3>(j3).setZero();
  ++n;
  base[n - 1] = axial_of(n - 1);  // the tissue's axial value when it joins: no jump
  travel0[n - 1] = tau, slip[n - 1] = 0.0, sliding[n - 1] = false, sign[n - 1] = 1.0;
}

double HapticNeedle::Impl::axial_of(std::size_t j) const {
  Vec<3> v = cu0.segment<3>(static_cast<Eigen::Index>(3 * j));
  for (std::size_t k = 0; k < n; ++k)
    v -= M.block<3, 3>(static_cast<Eigen::Index>(3 * j), static_cast<Eigen::Index>(3 * k)) *
         nu.segment<3>(static_cast<Eigen::Index>(3 * k));
  return F.col(2).dot(v);
}

// μ of the rows in frame F: the axial rows of sliding stations carry their limit, the others hold their
// values (S_ff μ_f = r_f − S_fs μ_s, an in-place Cholesky of S_ff); ν_j = F μ_j in model axes.
void HapticNeedle::Impl::solve_set() {
  const auto m3 = static_cast<Eigen::Index>(3 * n);
  const double limit = opt.max_shear_per_length * opt.spacing;
  free_rows.clear();
  for (Eigen::Index a = 0; a < m3; ++a) {
    const auto j = static_cast<std::size_t>(a / 3);
    if (a % 3 == 2 && sliding[j])
      mu[a] = -sign[j] * limit;
    else
      free_rows.push_back(static_cast<int>(a));
  }
  const auto nf = static_cast<Eigen::Index>(free_rows.size());
  for (Eigen::Index a = 0; a < nf; ++a) {
    rhs[a] = r[free_rows[a]];
    for (Eigen::Index b = 0; b < m3; ++b)
      if (b % 3 == 2 && sliding[static_cast<std::size_t>(b / 3)]) rhs[a] -= S(free_rows[a], b) * mu[b];
    for (Eigen::Index b = 0; b <= a; ++b) L(a, b) = S(free_rows[a], free_rows[b]);
  }
  for (Eigen::Index j = 0; j < nf; ++j) {
    double d = L(j, j);
    for (Eigen::Index k = 0; k < j; ++k) d -= L(j, k) * L(j, k);
    if (!(d > 1e-14 * S(free_rows[j], free_rows[j])))
      throw fem::DependentPointConstraints("HapticNeedle: the stations' rows are dependent (a rigid band)");
    L(j, j) = std::sqrt(d);
    for (Eigen::Index i = j + 1; i < nf; ++i) {
      double v = L(i, j);
      for (Eigen::Index k = 0; k < j; ++k) v -= L(i, k) * L(j, k);
      L(i, j) = v / L(j, j);
    }
  }
  for (Eigen::Index i = 0; i < nf; ++i) {  // L y = rhs, Lᵀ x = y
    for (Eigen::Index k = 0; k < i; ++k) rhs[i] -= L(i, k) * rhs[k];
    rhs[i] /= L(i, i);
  }
  for (Eigen::Index i = nf - 1; i >= 0; --i) {
    for (Eigen::Index k = i + 1; k < nf; ++k) rhs[i] -= L(k, i) * rhs[k];
    rhs[i] /= L(i, i);
  }
  for (Eigen::Index a = 0; a < nf; ++a) mu[free_rows[a]] = rhs[a];
  for (std::size_t j = 0; j < n; ++j)
    nu.segment<3>(static_cast<Eigen::Index>(3 * j)) = F * mu.segment<3>(static_cast<Eigen::Index>(3 * j));
}

// The Schur system of the stations in frame F and the values they hold (sliding ones: their last value).
void HapticNeedle::Impl::assemble(const Vec<3>& tip) {
  for (std::size_t j = 0; j < n; ++j) {
    const auto j3 = static_cast<Eigen::Index>(3 * j);
    for (std::size_t k = 0; k <= j; ++k) {
      const auto k3 = static_cast<Eigen::Index>(3 * k);
      const Eigen::Matrix3d b = F.transpose() * M.block<3, 3>(j3, k3) * F;
      S.block<3, 3>(j3, k3) = b;
      S.block<3, 3>(k3, j3) = b.transpose();
    }
    for (int rr = 0; rr < 3; ++rr) S(j3 + rr, j3 + rr) += kappa[j][rr];
    const Vec<3> held(F.col(0).dot(tip - centre[j]), F.col(1).dot(tip - centre[j]), stick_value(j));
    r.segment<3>(j3) = F.transpose() * cu0.segment<3>(j3) - held;
  }
}

const HapticNeedle::Step& HapticNeedle::step(const Vec<3>& tip, const Vec<3>& direction) {
  Impl& h = *impl_;
  if (!tip.allFinite() || !(direction.norm() > 0.0) || !direction.allFinite())
    throw std::invalid_argument("HapticNeedle::step: the tip and a non-zero direction must be finite");
  const Vec<3> a = direction.normalized();
  h.F = needle_frame(a);
  if (!h.started) {
    h.started = true;
    h.prev_tip = h.track_end = tip;
  }
  h.tau += a.dot(tip - h.prev_tip);
  h.prev_tip = tip;
  while (h.n < h.opt.max_stations && (tip - h.track_end).dot(a) >= h.opt.spacing) {
    h.join(h.track_end + 0.5 * h.opt.spacing * a, a);
    h.track_end += h.opt.spacing * a;
  }
  const double limit = h.opt.max_shear_per_length * h.opt.spacing;
  Step& out = h.result;
  out.sweeps = 0;
  out.settled = false;
  bool changed = true;
  while (out.sweeps < h.opt.max_sweeps && changed) {
    h.assemble(tip);
    h.solve_set();
    ++out.sweeps;
    changed = false;
    for (std::size_t j = 0; j < h.n; ++j) {
      const double f = -h.mu[static_cast<Eigen::Index>(3 * j + 2)];
      if (!h.sliding[j] && std::abs(f) > limit * (1.0 + 1e-9)) {
        h.sliding[j] = true, h.sign[j] = f > 0.0 ? 1.0 : -1.0, changed = true;
      } else if (h.sliding[j]) {
        // a sliding station whose limit would need it ahead of the needle sticks again
        const double stick = h.base[j] + h.tau - h.travel0[j] - h.slip[j];
        const double w = h.axial_of(j) - h.kappa[j][2] * h.mu[static_cast<Eigen::Index>(3 * j + 2)];
        if ((w - stick) * h.sign[j] > 1e-12 * std::max(1.0, std::abs(stick)))
          h.sliding[j] = false, changed = true;
      }
    }
    out.settled = !changed;
  }
  if (!out.settled) h.assemble(tip), h.solve_set();  // the last set's solution
  for (std::size_t j = 0; j < h.n; ++j) {
    const double stick = h.base[j] + h.tau - h.travel0[j];
    if (h.sliding[j]) {
      const double w = h.axial_of(j) - h.kappa[j][2] * h.mu[static_cast<Eigen::Index>(3 * j + 2)];
      h.slip[j] = stick - w;
    }
    h.g_axial[j] = stick - h.slip[j];
  }
  out.stations = h.n;
  out.station_force.resize(h.n);
  out.sliding.resize(h.n);
  out.force.setZero();
  for (std::size_t j = 0; j < h.n; ++j) {
    out.station_force[j] = -h.nu.segment<3>(static_cast<Eigen::Index>(3 * j));
    out.force -= out.station_force[j];
    out.sliding[j] = h.sliding[j];
  }
  for (std::size_t p = 0; p < out.probe_displacement.size(); ++p) {
    Vec<3> u = h.pu0.segment<3>(static_cast<Eigen::Index>(3 * p));
    for (std::size_t j = 0; j < h.n; ++j)
      u -= h.P.block<3, 3>(static_cast<Eigen::Index>(3 * p), static_cast<Eigen::Index>(3 * j)) *
           h.nu.segment<3>(static_cast<Eigen::Index>(3 * j));
    out.probe_displacement[p] = u;
  }
  return out;
}

std::vector<PointConstraint<3>> HapticNeedle::constraints() const {
  const Impl& h = *impl_;
  std::vector<PointConstraint<3>> rows;
  for (std::size_t j = 0; j < h.n; ++j) {
    PointConstraint<3> p(h.centre[j]);
    p.axes = h.F;
    for (std::size_t q = 0; q < h.band_offsets.size(); ++q)
      p.offsets.push_back(h.frame[j] * h.band_offsets[q]);
    p.weights = h.band_weights;
    p.compliance = h.kappa[j];
    p.displacement = Vec<3>(h.F.col(0).dot(h.prev_tip - h.centre[j]),
                            h.F.col(1).dot(h.prev_tip - h.centre[j]), h.g_axial[j]);
    rows.push_back(std::move(p));
  }
  return rows;
}

}  // namespace vim::needle

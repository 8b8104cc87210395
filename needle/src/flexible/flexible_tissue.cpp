// The tissue as a flexible needle sees it (vim/needle/flexible/flexible_tissue.hpp).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vim/needle/flexible/flexible_tissue.hpp>

namespace vim::needle {

namespace {

// The CLI's tissue as a flexible needle sees it: the condensed rows, their lateral values the
// deflected coupling's.
class CoupledTissue final : public DeflectableTissue {
 public:
  CoupledTissue(ElasticTissue<3>& tissue, DeflectedCoupling& coupling)
      : tissue_(tissue), coupling_(coupling) {}
  const std::vector<double>& solve(const std::vector<double>& axial) override { return tissue_.solve(axial); }
  const AxialMap& axial_map() override { return tissue_.axial_map(); }
  void set_deflection(const std::vector<Vec<3>>& deflection) override {
    coupling_.set_deflection(deflection);
  }
  Vec<3> active_force(std::size_t i) const override {
    const std::vector<Vec<3>>& f = tissue_.solution().point_force;
    return i < f.size() ? f[i] : Vec<3>::Zero();
  }

 private:
  ElasticTissue<3>& tissue_;
  DeflectedCoupling& coupling_;
};

}  // namespace

FlexibleTissue::FlexibleTissue(ElasticTissue<3>& tissue, DeflectedCoupling& coupling, const ShaftState& state,
                               const std::vector<ShaftPoint<3>>& stations, const Vec<3>& axis,
                               const FlexibleNeedle& needle, double element_length, std::size_t n_points,
                               double probe_step)
    : FlexibleTissue(std::make_unique<CoupledTissue>(tissue, coupling), nullptr, state, stations, axis,
                     needle, element_length, n_points, probe_step) {}

FlexibleTissue::FlexibleTissue(DeflectableTissue& tissue, const ShaftState& state,
                               const std::vector<ShaftPoint<3>>& stations, const Vec<3>& axis,
                               const FlexibleNeedle& needle, double element_length, std::size_t n_points,
                               double probe_step)
    : FlexibleTissue(nullptr, &tissue, state, stations, axis, needle, element_length, n_points, probe_step) {}

FlexibleTissue::~FlexibleTissue() = default;

FlexibleTissue::FlexibleTissue(std::unique_ptr<DeflectableTissue> owned, DeflectableTissue* tissue,
                               const ShaftState& state, const std::vector<ShaftPoint<3>>& stations,
                               const Vec<3>& axis, const FlexibleNeedle& needle, double element_length,
                               std::size_t n_points, double probe_step)
    : owned_(std::move(owned)),
      tissue_(tissue ? *tissue : *owned_),
      state_(state),
      axis_(axis.normalized()),
      needle_(needle),
      element_(element_length),
      probe_step_(probe_step),
      n_points_(n_points),
      beam_(needle.bending_stiffness(), {0.0, element_length}) {
  if (!(element_length > 0.0)) throw std::invalid_argument("FlexibleTissue: element length must be > 0");
  for (const auto& p : stations) s_.push_back(p.s);
  channel_.assign(s_.size(), Vec<3>::Zero());
  cut_.assign(s_.size(), false);
  // The bending planes: any two directions normal to the axis (a round tube bends alike in all).
  e_[0] = axis_.unitOrthogonal();
  e_[1] = axis_.cross(e_[0]);
}

void FlexibleTissue::hold_base(double free_length, const Vec<3>& slope) {
  if (!(free_length >= 0.0))
    throw std::invalid_argument("FlexibleTissue: the holder must not be past the entry");
  needle_.free_length = free_length;
  base_slope_ = slope - slope.dot(axis_) * axis_;
}

// Nodes from the holder (−free_length) to the needle's end, elements at most element_ long; the entry
// is a node when the holder is before it.
void FlexibleTissue::set_depth(double depth, const Vec<3>& bevel_direction, double bevel_ratio,
                               const Vec<3>& base_offset) {
  const Vec<3> tip = deflection(depth_), tangent = slope(depth_);
  for (std::size_t j = 0; j < s_.size(); ++j)
    if (!cut_[j] && s_[j] <= depth + element_) {
      channel_[j] = tip + (s_[j] - depth_) * tangent;
      cut_[j] = true;
    }
  depth_ = depth;
  bevel_direction_ = bevel_direction - bevel_direction.dot(axis_) * axis_;
  bevel_ratio_ = bevel_ratio;
  base_offset_ = base_offset - base_offset.dot(axis_) * axis_;
  std::vector<double> nodes;
  const auto add = [&](double from, double to) {
    const long n = std::max(1L, static_cast<long>(std::ceil((to - from) / element_ - 1e-9)));
    for (long i = nodes.empty() ? 0 : 1; i <= n; ++i)
      nodes.push_back(from + (to - from) * static_cast<double>(i) / static_cast<double>(n));
  };
  const double end = std::max(depth, 1e-6 * element_);
  if (needle_.free_length > 0.0) add(-needle_.free_length, 0.0);
  add(nodes.empty() ? 0.0 : nodes.back(), end);
  beam_ = Beam(needle_.bending_stiffness(), std::move(nodes));
  assembled_ = false;
  map_valid_ = false;
}

Eigen::VectorXd FlexibleTissue::lateral_forces() const {
  Eigen::VectorXd lat(static_cast<Eigen::Index>(2 * stations_.size()));
  for (std::size_t i = 0; i < stations_.size(); ++i) {
    const Vec<3> f = tissue_.active_force(slots_[i]);
    for (int p = 0; p < 2; ++p)
      lat[static_cast<Eigen::Index>(2 * i + static_cast<std::size_t>(p))] = f.dot(e_[p]);
  }
  return lat;
}

// The lateral stiffness of the active stations' rows: the tissue's force response to a unit lateral
// value at each (the rows' compliance in series included), 2m + 1 solves.
void FlexibleTissue::measure_lateral_stiffness(const std::vector<double>& axial) {
  stations_.clear();
  slots_.clear();
  for (std::size_t i = 0; i < state_.active.size(); ++i)
    if (state_.active[i] < s_.size()) stations_.push_back(state_.active[i]), slots_.push_back(i);
  const auto m2 = static_cast<Eigen::Index>(2 * stations_.size());
  std::vector<Vec<3>> d(n_points_, Vec<3>::Zero());
  tissue_.set_deflection(d);
  tissue_.solve(axial);
  const Eigen::VectorXd f0 = lateral_forces();
  a_.resize(m2, m2);
  for (std::size_t i = 0; i < stations_.size(); ++i)
    for (int p = 0; p < 2; ++p) {
      d[stations_[i]] = probe_step_ * e_[p];
      tissue_.set_deflection(d);
      tissue_.solve(axial);
      a_.col(static_cast<Eigen::Index>(2 * i + static_cast<std::size_t>(p))) =
          (lateral_forces() - f0) / probe_step_;
      d[stations_[i]] = Vec<3>::Zero();
    }
  a_ = (0.5 * (a_ + a_.transpose())).eval();  // symmetric up to round-off
  a_active_ = state_.active;
  assembled_ = false;
}

// K + Nᵀ A N over both planes (DOFs of plane p at p·n_dofs), the base's w and θ held.
void FlexibleTissue::assemble() {
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  const auto m = static_cast<Eigen::Index>(stations_.size());
  n_ = Eigen::MatrixXd::Zero(2 * m, 2 * nd);
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::RowVectorXd row = beam_.deflection_row(s_[stations_[static_cast<std::size_t>(i)]]);
    for (Eigen::Index p = 0; p < 2; ++p) n_.block(2 * i + p, p * nd, 1, nd) = row;
  }
  system_ = Eigen::MatrixXd::Zero(2 * nd, 2 * nd);
  for (Eigen::Index p = 0; p < 2; ++p) system_.block(p * nd, p * nd, nd, nd) = beam_.stiffness();
  system_ += n_.transpose() * a_ * n_;
  free_.clear();
  for (Eigen::Index k = 0; k < 2 * nd; ++k)
    if (k % nd >= 2) free_.push_back(k);  // node 0 of each plane: clamped
  const auto nf = static_cast<Eigen::Index>(free_.size());
  Eigen::MatrixXd ff(nf, nf);
  for (Eigen::Index i = 0; i < nf; ++i)
    for (Eigen::Index j = 0; j < nf; ++j) ff(i, j) = system_(free_[i], free_[j]);
  factor_.compute(ff);
  if (factor_.info() != Eigen::Success)
    throw std::runtime_error("FlexibleTissue: the beam system is singular");
  assembled_ = true;
}

void FlexibleTissue::set_deflection(const Eigen::VectorXd& q) {
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  std::vector<Vec<3>> d(n_points_, Vec<3>::Zero());
  for (std::size_t j : stations_) {
    const Eigen::RowVectorXd row = beam_.deflection_row(s_[j]);
    d[j] = row.dot(q.head(nd)) * e_[0] + row.dot(q.tail(nd)) * e_[1] - channel_[j];
  }
  tissue_.set_deflection(d);
}

const std::vector<double>& FlexibleTissue::solve(const std::vector<double>& axial) {
  if (a_active_ != state_.active) measure_lateral_stiffness(axial);
  if (!assembled_) assemble();
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  // F₀: the tissue's forces with the needle on the planned line; the bevel's load from its tip force.
  set_deflection(Eigen::VectorXd::Zero(2 * nd));
  const std::vector<double>& f0 = tissue_.solve(axial);
  rhs_ = -n_.transpose() * lateral_forces();
  const double tip_force = state_.cutting < f0.size() ? std::max(0.0, f0[state_.cutting]) : 0.0;
  const Vec<3> bevel = bevel_ratio_ * tip_force * bevel_direction_;
  const Eigen::RowVectorXd tip = beam_.deflection_row(beam_.nodes().back());
  for (Eigen::Index p = 0; p < 2; ++p) rhs_.segment(p * nd, nd) += bevel.dot(e_[p]) * tip.transpose();
  // The held DOFs: the base's deflection at the holder's offset, its slope the holder's; their columns
  // to the right.
  q_ = Eigen::VectorXd::Zero(2 * nd);
  for (Eigen::Index p = 0; p < 2; ++p)
    q_[p * nd] = base_offset_.dot(e_[p]), q_[p * nd + 1] = base_slope_.dot(e_[p]);
  const Eigen::VectorXd load = rhs_ - system_ * q_;
  const auto nf = static_cast<Eigen::Index>(free_.size());
  Eigen::VectorXd b(nf);
  for (Eigen::Index i = 0; i < nf; ++i) b[i] = load[free_[i]];
  const Eigen::VectorXd x = factor_.solve(b);
  for (Eigen::Index i = 0; i < nf; ++i) q_[free_[i]] = x[i];
  set_deflection(q_);
  forces_ = tissue_.solve(axial);
  return forces_;
}

const AxialMap& FlexibleTissue::axial_map() {
  if (map_valid_ && map_active_ == state_.active) return map_;
  map_ = probe_axial_map(*this, state_, n_points_, probe_step_);
  map_active_ = state_.active;
  map_valid_ = true;
  return map_;
}

Vec<3> FlexibleTissue::deflection(double s) const {
  if (q_.size() != 2 * static_cast<Eigen::Index>(beam_.n_dofs())) return Vec<3>::Zero();
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  const Eigen::RowVectorXd row = beam_.deflection_row(s);
  return row.dot(q_.head(nd)) * e_[0] + row.dot(q_.tail(nd)) * e_[1];
}

Vec<3> FlexibleTissue::slope(double s) const {
  if (q_.size() != 2 * static_cast<Eigen::Index>(beam_.n_dofs())) return Vec<3>::Zero();
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  const Eigen::RowVectorXd row = beam_.slope_row(s);
  return row.dot(q_.head(nd)) * e_[0] + row.dot(q_.tail(nd)) * e_[1];
}

// The base's reactions: the residual of the held rows, (K + NᵀAN) q − f at w and θ of node 0: the
// lateral force and the moment (about the normal of each plane) the holder applies to the needle.
Vec<3> FlexibleTissue::base_force() const {
  if (q_.size() != system_.rows()) return Vec<3>::Zero();
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  Vec<3> f = Vec<3>::Zero();
  for (Eigen::Index p = 0; p < 2; ++p) f += (system_.row(p * nd).dot(q_) - rhs_[p * nd]) * e_[p];
  return f;
}

Vec<3> FlexibleTissue::base_moment() const {
  if (q_.size() != system_.rows()) return Vec<3>::Zero();
  const auto nd = static_cast<Eigen::Index>(beam_.n_dofs());
  // The bending moment M_p in plane p (about axis × e_p, positive where it raises θ_p).
  Vec<3> m = Vec<3>::Zero();
  for (Eigen::Index p = 0; p < 2; ++p)
    m += (system_.row(p * nd + 1).dot(q_) - rhs_[p * nd + 1]) * axis_.cross(e_[p]);
  return m;
}

}  // namespace vim::needle

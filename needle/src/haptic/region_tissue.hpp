// The condensed region behind the real-time needle (vim/needle/haptic_needle.hpp): the tissue its
// stepping solves, a TissueResponse whose rows follow the needle's pose (and a flexible needle's
// deflection). Per station j and model axis d the row c_{j,d} (the band mean of the shape functions along
// e_d, over the region's free DoFs, Dirichlet values as a constant h_{j,d}) is formed once, when the band
// is placed, with Y_{j,d} = W c_{j,d}; the blocks M_jk = [c_{j,d}·Y_{k,d'}] (3×3, model axes) and the
// probes' blocks P_pj = [π_{p,d}·Y_{j,d'}] then give every solve's Schur system in the current needle
// frame F:
//   S_(jr)(ks) = F_rᵀ M_jk F_s + δ κ_jr,  S μ = F_rᵀ(c_j·u0 + h_j) − g_jr,
// the force on the tissue at station j −F μ_j, and u(p) = π_p·u0 + h_p − Σ_j P_pj F μ_j. S is factorised
// once per step; the axial map of the law is the axial block of S⁻¹ (f_j = −μ_j,axial is affine in the
// axial values g_j,axial). The tip's disk (the tip bearing, when the law cuts) is one more slot, formed
// like a station when the tip starts pressing a disk, of which only the axial row a = F_2 enters S:
//   S_(tip)(ks) = aᵀ M_tk F_s,  S_(tip)(tip) = aᵀ M_tt a + κ_tip,  b_tip = a·(c_t·u0 + h_t).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>
#include <vector>
#include <vim/fem/condensed_region.hpp>
#include <vim/fem/conditions.hpp>
#include <vim/fem/model.hpp>
#include <vim/needle/axial_map.hpp>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/flexible/deflectable_tissue.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/needle/shaft_state.hpp>

namespace vim::needle::haptic {

using Term = fem::CondensedRegion::Term;
using Index = Eigen::Index;

// A row's sample pattern in frame coordinates (l1, l2, axis) with its weights.
struct Pattern {
  std::vector<Vec<3>> offsets;
  std::vector<double> weights;
};

inline Pattern pattern_of(const PointConstraint<3>& row) {
  Pattern p;
  for (const auto& off : row.offsets) p.offsets.push_back(row.axes.transpose() * off);
  p.weights = row.weights;
  return p;
}

// The condensed region behind the tissue interface: the placed stations' rows and the tip's disk (slot
// `cap`, axial only), their Schur system in the current frame, and the last solve's multipliers.
class RegionTissue final : public DeflectableTissue {
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
  // A flexible needle's deflection per point (model axes): added to the stations' lateral values.
  void set_deflection(const std::vector<Vec<3>>& deflection) override {
    for (std::size_t j = 0; j < cap_; ++j)
      deflection_[j] = j < deflection.size() ? deflection[j] : Vec<3>::Zero();
    rhs_set_ = false;
  }
  Vec<3> active_force(std::size_t i) const override { return point_force(state_->active[i]); }
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
  void factor();   // S of the active points in frame F, factorised in place, and set_rhs()
  void set_rhs();  // b of the active points
  Index rows() const;
  Index axial_row(std::size_t i) const {
    return i < ms_ ? static_cast<Index>(3 * i + 2) : static_cast<Index>(3 * ms_);
  }
  Vec<3> lateral(std::size_t j) const {
    const Vec<3> v = tip_at_ - centre_[j] + deflection_[j];
    return Vec<3>(F_.col(0).dot(v), F_.col(1).dot(v), 0.0);
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
  std::vector<Vec<3>> centre_, kappa_, deflection_;  // deflection_: a flexible needle's, per station
  std::vector<Eigen::Matrix3d> frame_;               // the frame its samples were placed in
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
  bool factored_ = false, rhs_set_ = false;
  std::size_t factored_m_ = 0, ms_ = 0;  // active points, of which stations
  Eigen::MatrixXd S_;
  Eigen::VectorXd b_, x_;  // F_rᵀ(c_j·u0 + h_j) − lateral; the solve's right-hand side and μ
  std::vector<double> forces_;
  AxialMap map_;
};

}  // namespace vim::needle::haptic

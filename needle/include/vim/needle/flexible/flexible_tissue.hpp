// The tissue as a flexible needle sees it (docs/needle-model.md, the flexible needle): the elastic tissue
// behind the coupling rows, with the needle's shaft an Euler–Bernoulli beam (Beam) clamped at its base
// (the entry, or a holder free_length before it) whose deflection from the channel the tip cut enters
// the rows' lateral values (DeflectedCoupling). A solve with the active points' axial values solves, in
// one linear system, the beam's deflection and the stations' lateral forces together:
//   F = F₀(w) + A N q  (F₀: the forces with the needle on the planned line, its rows at −c_j, c_j the
//   channel; A the tissue's lateral stiffness of the active rows, band compliance included: the
//   condensed Schur system),
//   (K_beam + Nᵀ A N) q = f_bevel − Nᵀ F₀(w),  base DOFs held (w at the holder's offset, θ = 0),
// then the tissue with those lateral values, whose axial forces it returns. A is measured once per
// active set with 2m + 1 tissue solves (the tissue is linear); F₀ with one solve per call. No
// alternating iteration: the stepping and the friction laws see an ordinary TissueResponse. The tissue is
// any DeflectableTissue: the CLI's condensed rows with their DeflectedCoupling, or the real-time
// needle's condensed region (HapticNeedle, whose base moves with the haptic device: hold_base).
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>
#include <vim/needle/elastic_tissue.hpp>
#include <vim/needle/flexible/beam.hpp>
#include <vim/needle/flexible/deflectable_tissue.hpp>
#include <vim/needle/flexible/deflected_coupling.hpp>
#include <vim/needle/shaft.hpp>

namespace vim::needle {

// The needle's tube (needle.flexible): E, d_o (needle.diameter), d_i and the holder's distance before
// the entry.
struct FlexibleNeedle {
  double youngs_modulus = 0.0, outer_diameter = 0.0, inner_diameter = 0.0, free_length = 0.0;
  double bending_stiffness() const {
    return youngs_modulus * tube_second_moment(outer_diameter, inner_diameter);
  }
};

class FlexibleTissue final : public TissueResponse {
 public:
  // `tissue` built on `coupling`; `stations`: the shaft points (their arc lengths s from the entry);
  // `axis`: the planned line's unit direction (frame); `element_length`: the beam's longest element.
  FlexibleTissue(ElasticTissue<3>& tissue, DeflectedCoupling& coupling, const ShaftState& state,
                 const std::vector<ShaftPoint<3>>& stations, const Vec<3>& axis, const FlexibleNeedle& needle,
                 double element_length, std::size_t n_points, double probe_step);
  // Any tissue whose rows take the deflection (it outlives this).
  FlexibleTissue(DeflectableTissue& tissue, const ShaftState& state,
                 const std::vector<ShaftPoint<3>>& stations, const Vec<3>& axis, const FlexibleNeedle& needle,
                 double element_length, std::size_t n_points, double probe_step);
  ~FlexibleTissue() override;

  // Before set_depth: the holder `free_length` before the entry along the planned line, and the
  // needle's slope there (the lateral part of its direction over the axial part, frame; 0: along the
  // planned line, as a template holds it).
  void hold_base(double free_length, const Vec<3>& slope);

  // The needle's end is at arc length `depth` from the entry at this step: the beam runs from the base to
  // it. The stations the tip reaches now take the channel it cuts: the last step's tip extended along
  // its tangent (the tip advances along its own tangent). A bevel puts a lateral force on the needle's
  // end, `bevel_ratio` × the tip's axial force (the cutting row's, ≥ 0) along the unit lateral
  // `bevel_direction` (frame; zero: a symmetric tip). `base_offset` (frame, its lateral part): the base
  // held there across the planned line, in the line's direction (the holder moved sideways).
  void set_depth(double depth, const Vec<3>& bevel_direction = Vec<3>::Zero(), double bevel_ratio = 0.0,
                 const Vec<3>& base_offset = Vec<3>::Zero());
  const std::vector<double>& solve(const std::vector<double>& axial) override;
  const AxialMap& axial_map() override;

  // Of the last solve: the needle's lateral deflection from the planned line and its slope (the
  // tangent's lateral part) at arc length s (frame), and the lateral force and moment the base holds
  // (on the needle, frame).
  Vec<3> deflection(double s) const;
  Vec<3> slope(double s) const;
  Vec<3> base_force() const;
  Vec<3> base_moment() const;
  const Beam& beam() const { return beam_; }
  double depth() const { return depth_; }

 private:
  Eigen::VectorXd lateral_forces() const;  // of the tissue's last solve: (F·e₀, F·e₁) per active station
  void measure_lateral_stiffness(const std::vector<double>& axial);
  void assemble();
  void set_deflection(const Eigen::VectorXd& q);

  FlexibleTissue(std::unique_ptr<DeflectableTissue> owned, DeflectableTissue* tissue, const ShaftState& state,
                 const std::vector<ShaftPoint<3>>& stations, const Vec<3>& axis, const FlexibleNeedle& needle,
                 double element_length, std::size_t n_points, double probe_step);

  std::unique_ptr<DeflectableTissue> owned_;  // the CLI's rows and coupling, adapted
  DeflectableTissue& tissue_;
  const ShaftState& state_;
  std::vector<double> s_;  // arc length per shaft point
  Vec<3> axis_, e_[2];     // the planned line's direction and the two bending planes' normals
  FlexibleNeedle needle_;
  double element_ = 0.0, probe_step_ = 0.0, depth_ = 0.0;
  std::size_t n_points_ = 0;
  Beam beam_;
  Vec<3> bevel_direction_ = Vec<3>::Zero();
  double bevel_ratio_ = 0.0;
  Vec<3> base_offset_ = Vec<3>::Zero(), base_slope_ = Vec<3>::Zero();
  std::vector<Vec<3>> channel_;        // per station: the lateral position of the channel the tip cut there
  std::vector<bool> cut_;              // its channel is set
  std::vector<std::size_t> stations_;  // the active shaft stations (not tip rows), and their slot in active
  std::vector<std::size_t> slots_;
  Eigen::MatrixXd a_;                    // lateral stiffness of the active stations (2m × 2m)
  std::vector<std::size_t> a_active_;    // the active set A was measured for
  Eigen::MatrixXd n_;                    // 2m × 2·dofs: station deflections from q (both planes)
  Eigen::MatrixXd system_;               // K + Nᵀ A N (both planes)
  std::vector<Eigen::Index> free_;       // its free DOFs (the base's are held)
  Eigen::LDLT<Eigen::MatrixXd> factor_;  // of its free block
  bool assembled_ = false;
  Eigen::VectorXd q_, rhs_;  // the last solve's DOFs (both planes) and load
  std::vector<double> forces_;
  AxialMap map_;
  std::vector<std::size_t> map_active_;
  bool map_valid_ = false;
};

}  // namespace vim::needle

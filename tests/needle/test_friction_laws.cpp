// The friction laws and the line coupling (vim/needle/friction_law.hpp, vim/needle/line_coupling.hpp) against
// a tissue solved by hand: a diagonal spring map f_j = k_j·w_j (every shaft point on its own spring), for
// which the stick values, the force-controlled values target/k and the stick-slip limits follow in closed
// form; the coupling's rows against the axis and offsets written out by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vim/needle/friction_law.hpp>
#include <vim/needle/line_coupling.hpp>

using namespace vim;
using namespace vim::needle;

namespace {

// Independent springs: the axial force of active point j is k_j·w_j.
class Springs final : public TissueResponse {
 public:
  Springs(std::vector<double> k, const ShaftState& state) : k_(std::move(k)), state_(state) {}
  const std::vector<double>& solve(const std::vector<double>& axial) override {
    ++solves;
    last = axial;
    f_.assign(k_.size(), 0.0);
    for (std::size_t j : state_.active) f_[j] = k_[j] * axial[j];
    return f_;
  }
  const AxialMap& axial_map() override {
    const auto m = static_cast<Eigen::Index>(state_.active.size());
    map_.K = Eigen::MatrixXd::Zero(m, m);
    map_.c = Eigen::VectorXd::Zero(m);
    for (Eigen::Index i = 0; i < m; ++i) map_.K(i, i) = k_[state_.active[static_cast<std::size_t>(i)]];
    return map_;
  }
  int solves = 0;
  std::vector<double> last;  // the values of the last solve

 private:
  std::vector<double> k_;
  const ShaftState& state_;
  AxialMap map_;
  std::vector<double> f_;
};

// Three active points, the last pushed by the tip, each carrying 1 of shaft, all stuck at 0.5.
ShaftState three_points() {
  ShaftState s;
  s.active = {0, 1, 2};
  s.tip = 2;
  s.joined.assign(3, false);
  s.axial.assign(3, 0.2);  // last step's values
  s.stick.assign(3, 0.5);
  s.carried.assign(3, 1.0);
  return s;
}

FrictionOptions law_options(const char* law) {
  FrictionOptions n;
  n.law = law;
  n.max_sweeps = 100;
  return n;
}

// The kinematic stick-slip law with a sliding limit of 1 per unit length, started on three points.
std::unique_ptr<FrictionLaw> stick_slip_limit_one() {
  FrictionOptions n = law_options("stick-slip");
  n.max_shear_per_length = 1.0;
  auto law = make_friction_law(n);
  law->start(3);
  return law;
}

}  // namespace

TEST(FrictionLaw, StickMovesEveryPointWithTheNeedleInOneSolve) {
  ShaftState s = three_points();
  Springs tissue({10.0, 1.0, 0.5}, s);
  auto law = make_friction_law(law_options("stick"));
  law->start(3);
  law->update(s, tissue);
  EXPECT_EQ(tissue.solves, 1);
  for (std::size_t j = 0; j < 3; ++j) EXPECT_DOUBLE_EQ(s.axial[j], 0.5);
  EXPECT_EQ(tissue.last, s.axial);  // the step's solution is the last solve
  EXPECT_TRUE(law->axial_force_never_falls());
  EXPECT_FALSE(law->has_active_set());
}

TEST(FrictionLaw, ForceModelGivesFrictionAndTipForce) {
  // Targets: friction 2 per unit carried length, tip force 5 on the pushed point: f = (2, 2, 7),
  // so w = f / k = (0.2, 2, 14).
  ShaftState s = three_points();
  Springs tissue({10.0, 1.0, 0.5}, s);
  FrictionOptions n = law_options("force");
  n.friction_per_length = 2.0;
  n.tip_force = 5.0;
  auto law = make_friction_law(n);
  law->start(3);
  law->update(s, tissue);
  EXPECT_NEAR(s.axial[0], 0.2, 1e-14);
  EXPECT_NEAR(s.axial[1], 2.0, 1e-14);
  EXPECT_NEAR(s.axial[2], 14.0, 1e-13);
  EXPECT_EQ(tissue.last, s.axial);
}

TEST(FrictionLaw, StickSlipSlidesOnlyWhereTheStuckForceExceedsTheLimit) {
  // Limit 1 per unit length. Stuck at 0.5 the forces are 5, 0.5, 0.25: point 0 slides to w = 1/10,
  // the others stay on the needle. A second step (the needle 0.1 further) keeps point 0 at its limit.
  ShaftState s = three_points();
  Springs tissue({10.0, 1.0, 0.5}, s);
  auto law = stick_slip_limit_one();
  const FrictionStep step = law->update(s, tissue);
  EXPECT_TRUE(step.settled);
  EXPECT_GE(step.sweeps, 1);
  EXPECT_NEAR(s.axial[0], 0.1, 1e-14);
  EXPECT_DOUBLE_EQ(s.axial[1], 0.5);
  EXPECT_DOUBLE_EQ(s.axial[2], 0.5);
  EXPECT_EQ(tissue.last, s.axial);

  for (std::size_t j = 0; j < 3; ++j) s.stick[j] = s.axial[j] + 0.1;
  law->update(s, tissue);
  EXPECT_NEAR(s.axial[0], 0.1, 1e-14);
  EXPECT_DOUBLE_EQ(s.axial[1], 0.6);
  EXPECT_DOUBLE_EQ(s.axial[2], 0.6);
  EXPECT_TRUE(law->has_active_set());
}

TEST(FrictionLaw, StickSlipPointSticksAgainWhenTheNeedleWouldOvertakeIt) {
  // A sliding point whose limit would need it ahead of the needle (the needle stuck value is below its
  // sliding value) is put back on the needle.
  ShaftState s = three_points();
  Springs tissue({10.0, 1.0, 0.5}, s);
  auto law = stick_slip_limit_one();
  law->update(s, tissue);  // point 0 slides at w = 0.1
  s.stick = {0.05, 0.5, 0.5};
  law->update(s, tissue);
  EXPECT_DOUBLE_EQ(s.axial[0], 0.05);
}

TEST(LineCoupling, RowsHoldThePointsOnTheAxisAtTheirAxialValues) {
  using V = Eigen::Vector3d;
  const V axis = V(1, 2, 2) / 3.0;
  Eigen::Matrix3d axes;  // a rotation about z by 90 degrees: constraint axes other than the frame's
  axes << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  LineCoupling<3> coupling({V(0, 0, 0), V(1, 2, 2), V(2, 4, 4)}, axis, axes);
  coupling.keep_offsets({V(0, 0, 0), V(0.3, 0, 0), V(0, 0, 0)});
  const auto rows = coupling.rows({1, 2}, {0.0, 0.6, 0.9});
  ASSERT_EQ(rows.size(), 2u);
  // Point 1: 0.6·axis + (the offset's part across the axis: (0.3,0,0) − 0.1·axis).
  const V u1 = 0.6 * axis + V(0.3, 0, 0) - 0.1 * axis;
  EXPECT_TRUE(rows[0].position.isApprox(V(1, 2, 2)));
  EXPECT_NEAR((axes * rows[0].displacement - u1).norm(), 0.0, 1e-15);
  EXPECT_NEAR((axes * rows[1].displacement - 0.9 * axis).norm(), 0.0, 1e-15);
  EXPECT_TRUE(rows[1].axes.isApprox(axes));

  fem::Solution<3> sol;
  sol.point_force = {V(3, 0, 0), V(0, 3, 3)};
  const auto f = coupling.axial_forces({1, 2}, sol);
  EXPECT_DOUBLE_EQ(f[0], 0.0);
  EXPECT_NEAR(f[1], 1.0, 1e-15);
  EXPECT_NEAR(f[2], 4.0, 1e-15);
}

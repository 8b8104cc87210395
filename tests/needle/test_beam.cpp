// The flexible needle's Euler–Bernoulli beam (vim/needle/flexible/beam.hpp) against closed forms: the
// cantilever under a tip load, and the semi-infinite beam on a Winkler foundation (Hetényi 1946).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vim/needle/flexible/beam.hpp>

using namespace vim::needle;

namespace {
// An 18 G steel needle: d_o = 1.27 mm, d_i = 0.84 mm, E = 200 GPa = 2e8 kPa (mm, kPa, mN).
constexpr double kSteel = 2e8;
double needle_ei() { return kSteel * tube_second_moment(1.27, 0.84); }
}  // namespace

TEST(Beam, TubeSecondMomentIsTheAnnulus) {
  // I = π(d_o⁴ − d_i⁴)/64, also the solid rod minus the bore.
  EXPECT_NEAR(tube_second_moment(1.27, 0.84), M_PI / 64 * (2.60144641 - 0.49787136), 1e-9);
  EXPECT_NEAR(tube_second_moment(2.0, 0.0), M_PI / 4, 1e-14);
  EXPECT_THROW(tube_second_moment(1.0, 1.0), std::invalid_argument);
  EXPECT_THROW(tube_second_moment(1.0, -0.1), std::invalid_argument);
}

// Clamped at s = 0 (w = θ = 0), a lateral load P at the tip s = L: w(L) = PL³/(3EI), θ(L) = PL²/(2EI),
// and along the beam w(x) = Px²(3L − x)/(6EI).
TEST(Beam, CantileverTipLoadMatchesClosedForm) {
  const double ei = needle_ei(), length = 60.0, p = 10.0;
  for (int elements : {4, 32}) {
    const Beam beam = Beam::uniform(ei, 0.0, length, elements);
    Eigen::MatrixXd f = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(beam.n_dofs()), 1);
    f.col(0) += p * beam.deflection_row(length).transpose();
    const Eigen::MatrixXd q = solve_held(beam.stiffness(), f, {0, 1}, Eigen::MatrixXd::Zero(2, 1));
    const double w = beam.deflection(q.col(0), length), theta = beam.slope(q.col(0), length);
    const double w_exact = p * std::pow(length, 3) / (3 * ei), theta_exact = p * length * length / (2 * ei);
    std::printf("cantilever, %d elements: w(L)/exact = %.6f, theta(L)/exact = %.6f\n", elements, w / w_exact,
                theta / theta_exact);
    EXPECT_NEAR(w / w_exact, 1.0, 5e-3) << elements << " elements";
    EXPECT_NEAR(theta / theta_exact, 1.0, 5e-3) << elements << " elements";
    for (double x : {7.3, 21.0, 44.4}) {
      const double wx = p * x * x * (3 * length - x) / (6 * ei);
      EXPECT_NEAR(beam.deflection(q.col(0), x) / wx, 1.0, 5e-3)
          << "x = " << x << ", " << elements << " elements";
    }
  }
}

// A beam on independent springs k·s at stations s apart (the midpoints of equal segments, as the band
// stations are), its end s = 0 displaced by w₀ with free rotation, the far end free and beyond the
// decay (βL = 8): the semi-infinite beam on an elastic foundation, w(x) = w₀ e^(−βx) cos βx,
// β = (k/(4EI))^(1/4) (Hetényi, Beams on Elastic Foundation, 1946, §10). Within 1% of w₀ along the beam.
TEST(Beam, WinklerFoundationDecaysAsHetenyi) {
  const double ei = needle_ei(), k = 100.0, w0 = 0.5;  // k: force per length per displacement (kPa)
  const double beta = std::pow(k / (4 * ei), 0.25);
  const double length = 8.0 / beta, station = 0.05 / beta;  // β s = 0.05 ≪ 1
  const int elements = 100;
  const Beam beam = Beam::uniform(ei, 0.0, length, elements);
  Eigen::MatrixXd a = beam.stiffness();
  const int stations = static_cast<int>(std::round(length / station));
  const double ds = length / stations;
  for (int j = 0; j < stations; ++j) {
    const Eigen::RowVectorXd n = beam.deflection_row((j + 0.5) * ds);
    a += k * ds * n.transpose() * n;
  }
  const Eigen::MatrixXd f = Eigen::MatrixXd::Zero(a.rows(), 1);
  const Eigen::MatrixXd q = solve_held(a, f, {0}, Eigen::MatrixXd::Constant(1, 1, w0));
  double worst = 0.0;
  for (int i = 0; i <= 200; ++i) {
    const double x = length * i / 200.0;
    const double exact = w0 * std::exp(-beta * x) * std::cos(beta * x);
    worst = std::max(worst, std::abs(beam.deflection(q.col(0), x) - exact) / w0);
  }
  std::printf("Winkler foundation: max |w - exact| / w0 = %.2e, theta(0)/(-beta w0) = %.5f\n", worst,
              beam.slope(q.col(0), 0.0) / (-beta * w0));
  EXPECT_LT(worst, 0.01);
  // The slope at the loaded end: θ(0) = −β w₀.
  EXPECT_NEAR(beam.slope(q.col(0), 0.0) / (-beta * w0), 1.0, 0.01);
}

TEST(Beam, RejectsBadInput) {
  EXPECT_THROW(Beam(0.0, {0.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(Beam(1.0, {0.0}), std::invalid_argument);
  EXPECT_THROW(Beam(1.0, {0.0, 1.0, 1.0}), std::invalid_argument);
  // A free beam (nothing held) is singular.
  const Beam beam = Beam::uniform(1.0, 0.0, 1.0, 2);
  EXPECT_THROW(solve_held(beam.stiffness(), Eigen::MatrixXd::Zero(6, 1), {}, Eigen::MatrixXd(0, 1)),
               std::runtime_error);
}

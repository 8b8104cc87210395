// Tests of averaged, compliant point constraints (vim/fem/point_constraints.hpp) and of the needle band
// rows (vim/needle/needle_band.hpp) against independent truth: a brute-force superposition of single-point
// constraints (the averaged row is the weighted mean of the point rows, its compliance a spring in
// series), the monolithic saddle-point solve, the row's own invariant force = (g − ū)/κ with ū sampled
// from the solution, and the same constraint with its outside samples removed by hand.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/needle_band.hpp>

#include "../fem/box_mesh.hpp"
#include "solutions_agree.hpp"

using namespace vim;
using namespace vim::fem;
using namespace vim::needle;
using ::testing::HasSubstr;

namespace {

// Unit cube, 6³ Kuhn boxes, bottom face held, no load: every displacement comes from the constraints.
ElasticModel<3> held_cube(unsigned degree) {
  const auto mesh = vim::test::kuhn_box<3>({{6, 6, 6}}, {{0.0, 0.0, 0.0}}, {{1.0, 1.0, 1.0}});
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = 1.0 + 0.5 * static_cast<double>(j % 7);
  ElasticModel<3> model(mesh, E, 0.35, degree);
  DirichletBC<3> held;
  held.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>::Ones(), 2, false, 1e-9);
  model.add_dirichlet(held);
  return model;
}

double max_norm(const std::vector<Vec<3>>& v) {
  double m = 0.0;
  for (const auto& x : v) m = std::max(m, x.norm());
  return m;
}

Eigen::Matrix3d tilted_frame() { return needle_frame(Vec<3>(0.3, -0.2, 1.0).normalized()); }

// Three stations tiling a tilted needle in the cube's interior, all compliant.
std::vector<PointConstraint<3>> tilted_stations(double modulus) {
  const Vec<3> axis = Vec<3>(0.3, -0.2, 1.0).normalized();
  NeedleBand band;
  band.radius = 0.02;
  band.coupling_radius = 0.11;
  band.length = 0.15;
  std::vector<PointConstraint<3>> pts;
  for (int k = 0; k < 3; ++k) {
    const Vec<3> centre = Vec<3>(0.47, 0.52, 0.45) + (k - 1.0) * band.length * axis;
    pts.push_back(needle_band_constraint(centre, axis, band, Vec<3>(0.004 * k, -0.002, 0.01 + 0.003 * k),
                                         modulus, 0.35));
  }
  return pts;
}

}  // namespace

// Brute force: with single point constraints of unit displacement at each sample x_q along d, the
// sampled solutions give the rows' Schur complement S_pq = d·u⁽q⁾(x_p) / F_q. The averaged constraint
// Σ w_q d·u(x_q) = g through a compliance κ then carries F = g / (wᵀSw + κ) and its field is
// Σ_q w_q F u⁽q⁾ / F_q. Checked for rigid and compliant rows, P1 and P2.
TEST(AveragedConstraint, IsTheWeightedMeanOfItsPointRows) {
  for (unsigned degree : {1u, 2u}) {
    auto model = held_cube(degree);
    const Eigen::Matrix3d axes = tilted_frame();
    const Vec<3> d = axes.col(2);
    PointConstraint<3> avg;
    avg.position = Vec<3>(0.48, 0.51, 0.6);
    avg.offsets = {Vec<3>(0.1, 0.0, 0.0), Vec<3>(-0.07, 0.05, 0.02), Vec<3>(0.0, -0.12, -0.05),
                   Vec<3>(0.03, 0.09, 0.1)};
    avg.weights = {1.0, 2.0, 0.5, 1.5};  // normalised by the solver: sum 5
    avg.axes = axes;
    avg.components = {{false, false, true}};
    avg.displacement = Vec<3>(0.0, 0.0, 0.02);
    const std::size_t n = avg.offsets.size();
    Eigen::MatrixXd S(n, n);
    std::vector<std::vector<Vec<3>>> unit_fields;
    std::vector<Vec<3>> samples;
    for (const auto& o : avg.offsets) samples.push_back(avg.position + o);
    for (std::size_t q = 0; q < n; ++q) {
      PointConstraint<3> p;
      p.position = samples[q];
      p.axes = axes;
      p.components = {{false, false, true}};
      p.displacement = Vec<3>(0.0, 0.0, 1.0);
      const auto sol = model.solve({p});
      const double Fq = sol.point_force[0].dot(d);
      ASSERT_GT(Fq, 0.0);
      const auto at = model.sample(samples);
      for (std::size_t r = 0; r < n; ++r) S(r, q) = at[r].dot(d) / Fq;
      unit_fields.push_back(sol.vertex_displacement);
      for (auto& u : unit_fields.back()) u /= Fq;
    }
    Eigen::VectorXd w(n);
    for (std::size_t q = 0; q < n; ++q) w[q] = avg.weights[q] / 5.0;
    const double wsw = w.dot(0.5 * (S + S.transpose()) * w);
    for (double kappa : {0.0, 0.7 * wsw}) {
      avg.compliance = Vec<3>(0.0, 0.0, kappa);
      const auto sol = model.solve({avg});
      const double F = 0.02 / (wsw + kappa);
      EXPECT_NEAR(sol.point_force[0].dot(d), F, 1e-7 * F) << "P" << degree << " κ " << kappa;
      EXPECT_LT((sol.point_force[0] - F * d).norm(), 1e-7 * F);
      std::vector<Vec<3>> expected(sol.vertex_displacement.size(), Vec<3>::Zero());
      for (std::size_t q = 0; q < n; ++q)
        for (std::size_t i = 0; i < expected.size(); ++i) expected[i] += w[q] * F * unit_fields[q][i];
      const double umax = max_norm(expected);
      ASSERT_GT(umax, 0.0);
      for (std::size_t i = 0; i < expected.size(); ++i)
        ASSERT_LT((sol.vertex_displacement[i] - expected[i]).norm(), 1e-7 * umax)
            << "P" << degree << " vertex " << i;
    }
  }
}

// Another solver: the cached Schur path and the monolithic saddle point [K Cᵀ; C −κ] agree.
TEST(AveragedConstraint, FastPathMatchesMonolithicWithCompliance) {
  for (unsigned degree : {1u, 2u}) {
    auto model = held_cube(degree);
    const auto pts = tilted_stations(2.0);
    const auto fast = model.solve(pts);
    const auto ref = model.solve_monolithic(pts);
    EXPECT_EQ(fast.stats.constraint_rows, 9u);
    EXPECT_EQ(ref.stats.constraint_rows, 9u);
    vim::test::expect_solutions_agree<3>(fast, ref, 1e-8, "P" + std::to_string(degree));
    if (HasFatalFailure()) return;
  }
}

// Invariant: a compliant row's force along axes.col(c) is (g_c − ū_c)/κ_c with ū the weighted mean of
// the solution sampled at the row's points; and the forces balance the support's reaction.
TEST(AveragedConstraint, CompliantForceIsTheSpringLaw) {
  for (unsigned degree : {1u, 2u}) {
    auto model = held_cube(degree);
    const auto pts = tilted_stations(2.0);
    const auto sol = model.solve(pts);
    Vec<3> total = Vec<3>::Zero();
    for (const auto& f : sol.point_force) total += f;
    for (const auto& r : sol.dirichlet_reaction) total += r;
    EXPECT_LT(total.norm(), 1e-9 * max_norm(sol.point_force));
    for (std::size_t k = 0; k < pts.size(); ++k) {
      std::vector<Vec<3>> at;
      for (const auto& o : pts[k].offsets) at.push_back(pts[k].position + o);
      const auto u = model.sample(at);
      Vec<3> mean = Vec<3>::Zero();
      for (const auto& v : u) mean += v / static_cast<double>(u.size());
      for (int c = 0; c < 3; ++c) {
        const double expected =
            (pts[k].displacement[c] - pts[k].axes.col(c).dot(mean)) / pts[k].compliance[c];
        const double got = sol.point_force[k].dot(pts[k].axes.col(c));
        ASSERT_GT(std::abs(expected), 1e-6);
        EXPECT_NEAR(got, expected, 1e-8 * std::abs(expected))
            << "P" << degree << " station " << k << " comp " << c;
      }
    }
  }
}

// A station whose ring crosses the face x = 0: its outside samples are left out and the others'
// weights renormalised — the same solution as the constraint built from the inside samples only.
// With every sample outside the constraint is refused, naming it.
TEST(AveragedConstraint, OutsideSamplesAreDroppedAndRenormalised) {
  auto model = held_cube(1);
  NeedleBand band;
  band.radius = 0.02;
  band.coupling_radius = 0.1;
  band.length = 0.2;
  const Vec<3> axis(0.0, 0.0, 1.0);
  auto edge = needle_band_constraint(Vec<3>(0.04, 0.5, 0.6), axis, band, Vec<3>(0.01, 0.0, 0.02), 2.0, 0.35);
  PointConstraint<3> inside = edge;
  inside.offsets.clear(), inside.weights.clear();
  for (std::size_t q = 0; q < edge.offsets.size(); ++q)
    if ((edge.position + edge.offsets[q])[0] >= 0.0)
      inside.offsets.push_back(edge.offsets[q]), inside.weights.push_back(edge.weights[q]);
  ASSERT_LT(inside.offsets.size(), edge.offsets.size());
  ASSERT_GT(inside.offsets.size(), 0u);
  const auto a = model.solve({edge});
  const auto b = model.solve_monolithic({inside});
  const double umax = max_norm(b.vertex_displacement);
  ASSERT_GT(umax, 0.0);
  for (std::size_t i = 0; i < a.vertex_displacement.size(); ++i)
    ASSERT_LT((a.vertex_displacement[i] - b.vertex_displacement[i]).norm(), 1e-9 * umax);
  EXPECT_LT((a.point_force[0] - b.point_force[0]).norm(), 1e-9 * b.point_force[0].norm());

  auto outside = edge;
  outside.position = Vec<3>(-0.5, 0.5, 0.6);
  try {
    model.solve({edge, outside});
    ADD_FAILURE() << "a constraint with every sample outside the mesh was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("point constraint 1"));
    EXPECT_THAT(e.what(), HasSubstr("all its averaging samples lie outside the mesh"));
  }
  EXPECT_THROW(model.solve_monolithic({outside}), std::invalid_argument);
}

// The band's samples lie on the cylinder of coupling radius R around the axis, within the band's
// length, in a right-handed frame whose third axis is the needle; bad bands are refused.
TEST(NeedleBand, SamplesLieOnTheCouplingCylinder) {
  const Vec<3> axis = Vec<3>(1.0, 2.0, -0.5).normalized();
  NeedleBand band;
  band.radius = 0.3;
  band.coupling_radius = 0.8;
  band.length = 1.5;
  const auto p = needle_band_constraint(Vec<3>(1, 2, 3), axis, band, Vec<3>::Zero(), 10.0, 0.4);
  EXPECT_LT((p.axes.transpose() * p.axes - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(p.axes.determinant(), 1.0, 1e-14);
  EXPECT_LT((p.axes.col(2) - axis).norm(), 1e-14);
  ASSERT_EQ(p.offsets.size(), static_cast<std::size_t>(band.n_theta * band.n_axial));
  Vec<3> mean = Vec<3>::Zero();
  for (const auto& o : p.offsets) {
    const double along = o.dot(axis);
    EXPECT_NEAR((o - along * axis).norm(), band.coupling_radius, 1e-12);
    EXPECT_LE(std::abs(along), 0.5 * band.length);
    mean += o / static_cast<double>(p.offsets.size());
  }
  EXPECT_LT(mean.norm(), 1e-12);  // the band is centred on its station
  EXPECT_GT(p.compliance.minCoeff(), 0.0);
  band.coupling_radius = band.radius;
  EXPECT_EQ(needle_band_constraint(Vec<3>::Zero(), axis, band, Vec<3>::Zero(), 10.0, 0.4).compliance.norm(),
            0.0);
  band.coupling_radius = 0.2;
  EXPECT_THROW(needle_band_constraint(Vec<3>::Zero(), axis, band, Vec<3>::Zero(), 10.0, 0.4),
               std::invalid_argument);
  band.coupling_radius = 0.8;
  band.length = 0.0;
  EXPECT_THROW(needle_band_constraint(Vec<3>::Zero(), axis, band, Vec<3>::Zero(), 10.0, 0.4),
               std::invalid_argument);
}

// The effective radius against its continuum integrals: one ring R; a solid cylinder of radius R
// (ln R_e = E[ln max(r, s)] for r, s uniform over the disk) R·e^(−1/4); a thin shell around a about a.
TEST(NeedleBand, EffectiveRadiusOfRingsAndCylinders) {
  NeedleBand band;
  band.radius = 0.1;
  band.coupling_radius = 2.0;
  band.length = 1.0;
  EXPECT_DOUBLE_EQ(effective_coupling_radius(band), 2.0);
  band.inner_fraction = 0.0;
  band.n_radial = 400;
  EXPECT_NEAR(effective_coupling_radius(band), 2.0 * std::exp(-0.25), 1e-5);
  const auto fine = needle_band_for(1.0, 0.05, 0.2, 1.0);
  EXPECT_NEAR(effective_coupling_radius(fine), 1.0, 1e-9);
  EXPECT_LT(fine.coupling_radius, 1.06);
  EXPECT_GT(fine.inner_fraction, 0.9);
  const auto coarse = needle_band_for(0.3, 4.0, 8.0, 1.0);
  EXPECT_DOUBLE_EQ(coarse.coupling_radius, 4.0);
  EXPECT_EQ(coarse.inner_fraction, 0.0);
  EXPECT_GT(effective_coupling_radius(coarse), 0.3);
  band.coupling_radius = 0.11;  // a solid cylinder whose effective radius is below the needle's
  EXPECT_THROW(needle_band_constraint(Vec<3>::Zero(), Vec<3>::UnitZ(), band, Vec<3>::Zero(), 1.0, 0.3),
               std::invalid_argument);
}

// Tests for vim/fem/condensed_constraints.hpp (rows condensed once, forces-only solves) against the
// monolithic saddle-point solve [K Cᵀ; C −κ] (ElasticModel::solve_monolithic, UMFPACK): point forces,
// probe displacements, held displacements and the whole field, P1 and P2, 2D and 3D; the dropping of
// dependent rows against ElasticModel::solve.
#include <gtest/gtest.h>

#include <algorithm>
#include <vim/fem/condensed_constraints.hpp>
#include <vim/fem/elasticity.hpp>

#include "box_conditions.hpp"
#include "box_mesh.hpp"
#include "needle_path_rows.hpp"

using namespace vim;
using namespace vim::fem;

namespace {

// A unit box, graded modulus, bottom face held, the x_min face pushed by 0.01 along x (an inhomogeneous
// condition), a body force.
template <int dim>
ElasticModel<dim> block(unsigned degree) {
  std::array<int, dim> cells;
  std::array<double, dim> lo, hi;
  cells.fill(dim == 2 ? 10 : 4), lo.fill(0.0), hi.fill(1.0);
  const auto mesh = test::kuhn_box<dim>(cells, lo, hi);
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = 1.0 + 3.0 * mesh.points[mesh.cells[j][0]][0];
  ElasticModel<dim> model(mesh, E, 0.45, degree);
  test::hold_and_push(model, false, 0.01);
  return model;
}

// A needle path from the top down: band rows (mean over four samples, a series compliance) and point
// rows alternating, the last one on the held corner (a void row).
template <int dim>
std::vector<PointConstraint<dim>> path() {
  std::vector<PointConstraint<dim>> path = vim::test::needle_path_rows<dim>(5, 0.17, 0.31, 0.013);
  path.push_back(PointConstraint<dim>(Vec<dim>::Zero()));  // on the held corner
  return path;
}

template <int dim>
double largest(const std::vector<Vec<dim>>& v) {
  double m = 0.0;
  for (const auto& x : v) m = std::max(m, x.norm());
  return m;
}

template <int dim>
void condensed_vs_monolithic(unsigned degree) {
  auto model = block<dim>(degree);
  const auto all = path<dim>();
  std::vector<Vec<dim>> probes = {Vec<dim>::Constant(0.25), Vec<dim>::Constant(0.7), Vec<dim>::Zero()};
  CondensedConstraints<dim> cc(model, all, probes);
  EXPECT_EQ(cc.n_rows(), dim * all.size());
  // the needle advances: the points join in an order that differs from the list's, the held corner early
  const std::vector<std::size_t> order = {0, 5, 2, 1, 3, 4};
  std::vector<std::size_t> active;
  std::vector<Vec<dim>> held;
  for (std::size_t step = 0; step < order.size(); ++step) {
    active.push_back(order[step]);
    held.assign(active.size(), Vec<dim>::Zero());
    std::vector<PointConstraint<dim>> rows;
    for (std::size_t i = 0; i < active.size(); ++i) {
      if (active[i] != 5) held[i][dim - 1] = -0.01 * static_cast<double>(step + 1 + i);
      rows.push_back(all[active[i]]);
      rows.back().displacement = held[i];
    }
    cc.solve(active, held);
    std::vector<Vec<dim>> force;
    cc.point_forces(force);
    const auto ref = model.solve_monolithic(rows);
    const double fmax = largest<dim>(ref.point_force);
    ASSERT_GT(fmax, 0);
    for (std::size_t i = 0; i < active.size(); ++i)
      EXPECT_LT((force[i] - ref.point_force[i]).norm(), 1e-8 * fmax) << "step " << step << " point " << i;
    // probes and held displacements against the monolithic field sampled there
    const auto at = model.sample(probes);
    const double umax = largest<dim>(ref.vertex_displacement);
    for (std::size_t p = 0; p < probes.size(); ++p)
      EXPECT_LT((cc.probe_displacements()[p] - at[p]).norm(), 1e-8 * umax)
          << "step " << step << " probe " << p;
    for (std::size_t j = 0; j < all.size(); ++j) {
      Vec<dim> mean = Vec<dim>::Zero();
      if (all[j].offsets.empty()) {
        mean = model.sample({all[j].position})[0];
      } else {
        double w = 0.0;
        for (std::size_t q = 0; q < all[j].offsets.size(); ++q) {
          mean += all[j].weights[q] * model.sample({Vec<dim>(all[j].position + all[j].offsets[q])})[0];
          w += all[j].weights[q];
        }
        mean /= w;
      }
      EXPECT_LT((cc.held_displacement(j) - mean).norm(), 1e-8 * umax) << "step " << step << " point " << j;
    }
    // the whole field on request
    const auto field = cc.field();
    for (std::size_t v = 0; v < ref.vertex_displacement.size(); ++v)
      ASSERT_LT((field.vertex_displacement[v] - ref.vertex_displacement[v]).norm(), 1e-8 * umax)
          << "step " << step;
    EXPECT_NEAR(field.strain_energy, ref.strain_energy, 1e-8 * ref.strain_energy) << "step " << step;
    for (std::size_t b = 0; b < ref.dirichlet_reaction.size(); ++b)
      EXPECT_LT((field.dirichlet_reaction[b] - ref.dirichlet_reaction[b]).norm(), 1e-8 * (fmax + 0.1));
    EXPECT_EQ(field.stats.constraint_rows, ref.stats.constraint_rows) << "step " << step;
  }
}

}  // namespace

TEST(CondensedConstraints, MatchMonolithicP2_3D) { condensed_vs_monolithic<3>(2); }
TEST(CondensedConstraints, MatchMonolithicP1_3D) { condensed_vs_monolithic<3>(1); }
TEST(CondensedConstraints, MatchMonolithicP1_2D) { condensed_vs_monolithic<2>(1); }
TEST(CondensedConstraints, MatchMonolithicP2_2D) { condensed_vs_monolithic<2>(2); }

// Truth: ElasticModel::solve on the same rows. Three collinear points inside one P1 triangle are
// dependent (P1 is affine there): the third row of each component is dropped when consistent, and a
// conflicting third point is an error.
TEST(CondensedConstraints, DropDependentRowsAsSolveDoes) {
  auto model = block<2>(1);
  std::vector<PointConstraint<2>> pts;
  for (int k = 0; k < 3; ++k) pts.emplace_back(Vec<2>(0.53 + 0.02 * k, 0.51 + 0.01 * k));  // one triangle
  CondensedConstraints<2> cc(model, pts, {});
  std::vector<Vec<2>> held(3, Vec<2>(0.0, -0.01));
  std::vector<PointConstraint<2>> rows = pts;
  for (auto& r : rows) r.displacement = Vec<2>(0.0, -0.01);
  cc.solve({0, 1, 2}, held);
  const auto ref = model.solve(rows);
  EXPECT_EQ(cc.stats().dependent_rows_dropped, ref.stats.dependent_rows_dropped);
  EXPECT_EQ(cc.stats().dependent_rows_dropped, 2u);
  std::vector<Vec<2>> force;
  cc.point_forces(force);
  for (int k = 0; k < 3; ++k)
    EXPECT_LT((force[k] - ref.point_force[k]).norm(), 1e-8 * largest<2>(ref.point_force));
  held[2] = Vec<2>(0.0, -0.02);
  rows[2].displacement = held[2];
  EXPECT_THROW(model.solve(rows), DependentPointConstraints);
  EXPECT_THROW(cc.solve({0, 1, 2}, held), DependentPointConstraints);
}

// CG + ML AMG with the rigid-body modes (pre-computed null space) vs the sparse direct solver on a
// heterogeneous 3D problem with more than 50k DoFs; also the AMG path with point constraints.
#include "box_mesh.hpp"

#include <vim/fem/elasticity.hpp>

#include <gtest/gtest.h>

#include <random>

using namespace vim;
using namespace vim::fem;

namespace {
ElasticModel<3> heterogeneous_block(int n, unsigned degree) {
  const auto mesh = test::kuhn_box<3>({{n, n, n}}, {{0, 0, 0}}, {{1, 1, 1}});
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> U(1.0, 10.0);
  std::vector<double> E(mesh.n_cells());
  for (auto& e : E) e = U(rng);
  ElasticModel<3> model(mesh, E, 0.4, degree);
  DirichletBC<3> bc;
  bc.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, false, 1e-9);
  model.add_dirichlet(bc);
  SurfaceLoad<3> load;
  load.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, true, 1e-9);
  load.traction = Vec<3>(0.2, -0.1, 0.0);
  load.pressure = 0.5;
  model.add_surface_load(load);
  model.set_body_force(Vec<3>(0, 0.1, -0.2));
  return model;
}

double max_rel_diff(const std::vector<Vec<3>>& a, const std::vector<Vec<3>>& b) {
  double d = 0, s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm()), s = std::max(s, b[i].norm());
  return d / s;
}
}  // namespace

TEST(Amg, MatchesDirectOnFiftyThousandDofs) {
  auto model = heterogeneous_block(25, 1);
  ASSERT_GE(model.n_dofs(), 50000u);
  SolverOptions direct;
  direct.type = SolverOptions::Type::direct;
  const auto ref = model.solve({}, direct);
  EXPECT_EQ(ref.stats.method, "cholmod");
  SolverOptions amg;
  amg.type = SolverOptions::Type::amg;
  amg.tolerance = 1e-12;
  const auto sol = model.solve({}, amg);
  EXPECT_EQ(sol.stats.method, "cg+amg");
  std::printf("AMG: %u DoFs, %u CG iterations, relative residual %.2e\n", sol.stats.n_dofs, sol.stats.iterations,
              sol.stats.residual);
  EXPECT_LT(max_rel_diff(sol.vertex_displacement, ref.vertex_displacement), 1e-8);
  EXPECT_NEAR(sol.strain_energy, ref.strain_energy, 1e-8 * ref.strain_energy);
  // with all six rigid-body modes the iteration count stays small (translations alone need ~3x more)
  EXPECT_LT(sol.stats.iterations, 200u);
  // `automatic` switches to AMG above direct_limit
  SolverOptions automatic;
  automatic.direct_limit = 1000;
  automatic.tolerance = 1e-12;
  EXPECT_EQ(model.solve({}, automatic).stats.method, "cg+amg");
  // the default limit for 3D (150k DoFs) keeps this ~50k-DoF model on the direct solver; 2D keeps 200k
  SolverOptions by_default;
  by_default.tolerance = 1e-12;
  EXPECT_EQ(by_default.direct_limit_for(3), 150000u);
  EXPECT_EQ(by_default.direct_limit_for(2), 200000u);
  ASSERT_LT(model.n_dofs(), by_default.direct_limit_for(3));
  EXPECT_EQ(model.solve({}, by_default).stats.method, "cholmod");
}

TEST(Amg, PointConstraintsOnAmgPathMatchMonolithic) {
  auto model = heterogeneous_block(8, 2);
  SolverOptions amg;
  amg.type = SolverOptions::Type::amg;
  amg.tolerance = 1e-13;
  std::vector<PointConstraint<3>> pts = {{Vec<3>(0.5, 0.5, 0.7), Vec<3>(0, 0, -0.02)},
                                         {Vec<3>(0.5, 0.5, 0.5), Vec<3>(0, 0, -0.02)}};
  const auto sol = model.solve(pts, amg);
  const auto ref = model.solve_monolithic(pts);
  EXPECT_LT(max_rel_diff(sol.vertex_displacement, ref.vertex_displacement), 1e-8);
  for (std::size_t k = 0; k < pts.size(); ++k)
    EXPECT_LT((sol.point_force[k] - ref.point_force[k]).norm(), 1e-7 * ref.point_force[k].norm());
}

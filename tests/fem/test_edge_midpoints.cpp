// Truth: the analytic solution of a column under its own weight with ν = 0, held at z = 0:
// u_z(z) = (b/E)(L z − z²/2), u_x = u_y = 0. It is quadratic, so P2 reproduces it exactly and
// edge_midpoint_displacement must return it at every edge midpoint (the P2 edge DoFs), while the
// mean of an edge's two vertex values (all P1 can give) misses it by (b/E)·Δz²/8 on edges along z.
#include <gtest/gtest.h>

#include <array>
#include <set>
#include <stdexcept>
#include <vector>
#include <vim/fem/elasticity.hpp>

#include "box_mesh.hpp"

using namespace vim;

namespace {

constexpr double E = 3.0, b = 2.0, L = 2.0;
double column(double z) { return b / E * (L * z - 0.5 * z * z); }

SimplexMesh<3> column_mesh() {
  return test::kuhn_mesh<3>({{{0.0, 0.5, 1.0}, {0.0, 0.5}, {0.0, 0.7, 1.2, 2.0}}});
}

std::vector<std::array<int, 2>> all_edges(const SimplexMesh<3>& mesh) {
  std::set<std::array<int, 2>> edges;
  for (const auto& c : mesh.cells)
    for (int a = 0; a < 4; ++a)
      for (int k = a + 1; k < 4; ++k)
        edges.insert(std::array<int, 2>{{std::min(c[a], c[k]), std::max(c[a], c[k])}});
  return {edges.begin(), edges.end()};
}

fem::ElasticModel<3> column_model(const SimplexMesh<3>& mesh, unsigned degree) {
  fem::ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), E), 0.0, degree);
  fem::DirichletBC<3> bottom;
  bottom.region = fem::box_face_region<3>(fem::Vec<3>(0, 0, 0), fem::Vec<3>(1, 0.5, L), 2, false, 1e-9);
  model.add_dirichlet(bottom);
  model.set_body_force(fem::Vec<3>(0, 0, b));
  return model;
}

}  // namespace

TEST(EdgeMidpoints, P2EdgeValuesAreTheQuadraticColumnSolution) {
  const SimplexMesh<3> mesh = column_mesh();
  fem::ElasticModel<3> model = column_model(mesh, 2);
  EXPECT_THROW(model.edge_midpoint_displacement({{{0, 1}}}), std::runtime_error);  // before a solve
  model.solve();
  const auto edges = all_edges(mesh);
  const auto u = model.edge_midpoint_displacement(edges);
  ASSERT_EQ(u.size(), edges.size());
  double largest_linear_miss = 0.0;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const double za = mesh.points[edges[e][0]][2], zb = mesh.points[edges[e][1]][2];
    const double z = 0.5 * (za + zb);
    EXPECT_NEAR(u[e][2], column(z), 1e-10) << "edge " << edges[e][0] << "-" << edges[e][1];
    EXPECT_NEAR(u[e][0], 0.0, 1e-10);
    EXPECT_NEAR(u[e][1], 0.0, 1e-10);
    largest_linear_miss =
        std::max(largest_linear_miss, std::abs(column(z) - 0.5 * (column(za) + column(zb))));
  }
  EXPECT_GT(largest_linear_miss, 0.05);  // the edge values are not an average of the vertices
}

TEST(EdgeMidpoints, P1GivesTheMeanOfTheVerticesAndNonEdgesAreRejected) {
  const SimplexMesh<3> mesh = column_mesh();
  fem::ElasticModel<3> model = column_model(mesh, 1);
  const fem::Solution<3> s = model.solve();
  const auto edges = all_edges(mesh);
  const auto u = model.edge_midpoint_displacement(edges);
  for (std::size_t e = 0; e < edges.size(); ++e)
    EXPECT_LE((u[e] - 0.5 * (s.vertex_displacement[edges[e][0]] + s.vertex_displacement[edges[e][1]])).norm(),
              1e-12);
  // Vertices 0 and the far corner share no cell.
  EXPECT_THROW(model.edge_midpoint_displacement({{{0, static_cast<int>(mesh.n_points()) - 1}}}),
               std::invalid_argument);
}

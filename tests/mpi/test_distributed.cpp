// solve_distributed on 2 ranks (simplex: parallel::fullydistributed::Triangulation, Trilinos CG + AMG; voxel:
// p4est parallel::distributed::Triangulation, 3D with CG + matrix-free geometric multigrid) vs the
// serial direct solve each rank also runs: simplex (P1, P2, 2D) and voxel models (3D, 2D); and
// distribute_solves with point constraints (compliance columns by distributed solves) vs the serial
// Schur solve.
#include <deal.II/base/mpi.h>
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <vim/fem/distributed.hpp>
#include <vim/fem/elasticity.hpp>

#include "../fem/box_mesh.hpp"
#include "box_conditions.hpp"

using namespace vim;
using namespace vim::fem;

namespace {
template <int dim>
void add_conditions(ElasticModel<dim>& model) {
  test::hold_and_push(model, true, -0.01);
  SurfaceLoad<dim> load;
  load.region = box_face_region<dim>(Vec<dim>::Zero(), Vec<dim>::Ones(), dim - 1, true, 1e-9);
  load.pressure = 0.3;
  load.traction[0] = 0.05;
  model.add_surface_load(load);
}

// The largest |sol_i − ref_i| and the largest |ref_i| over two lists of vectors or tensors.
template <class T>
std::pair<double, double> largest_difference(const std::vector<T>& ref, const std::vector<T>& sol) {
  double d = 0, s = 0;
  for (std::size_t i = 0; i < ref.size(); ++i)
    d = std::max(d, (sol[i] - ref[i]).norm()), s = std::max(s, ref[i].norm());
  return {d, s};
}

// The vertex displacements (1e-8 of the largest), strain energy (1e-8), cell stresses (1e-7 of the
// largest) and Dirichlet reactions (reaction_tol · (1 + |reaction|)) of `sol` against `ref`.
template <int dim>
void expect_same_fields(const Solution<dim>& ref, const Solution<dim>& sol, double reaction_tol) {
  const auto [d, s] = largest_difference(ref.vertex_displacement, sol.vertex_displacement);
  ASSERT_GT(s, 0);
  EXPECT_LT(d / s, 1e-8);
  EXPECT_NEAR(sol.strain_energy, ref.strain_energy, 1e-8 * ref.strain_energy);
  const auto [sd, ss] = largest_difference(ref.cell_stress, sol.cell_stress);
  ASSERT_GT(ss, 0);
  EXPECT_LT(sd / ss, 1e-7);
  for (std::size_t b = 0; b < ref.dirichlet_reaction.size(); ++b)
    EXPECT_LT((sol.dirichlet_reaction[b] - ref.dirichlet_reaction[b]).norm(),
              reaction_tol * (1 + ref.dirichlet_reaction[b].norm()));
}

template <int dim>
void compare(ElasticModel<dim>& model, const std::string& method = "cg+amg") {
  const int ranks = dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD);
  SolverOptions direct;
  direct.type = SolverOptions::Type::direct;
  const auto ref = model.solve({}, direct);
  SolverOptions amg;
  amg.tolerance = 1e-13;
  const auto sol = solve_distributed(model, MPI_COMM_WORLD, amg);
  EXPECT_EQ(sol.stats.method, method + " (mpi, " + std::to_string(ranks) + " ranks)");
  expect_same_fields(ref, sol, 1e-7);
}

template <int dim>
std::vector<double> random_moduli(std::size_t n) {
  std::mt19937 rng(42);  // same on every rank
  std::uniform_real_distribution<double> U(1.0, 8.0);
  std::vector<double> E(n);
  for (auto& e : E) e = U(rng);
  return E;
}

// The unit box of `cells` voxels with random moduli (the same on every rank).
template <int dim>
ElasticModel<dim> random_voxel_model(const std::array<long, dim>& cells, double poisson_ratio) {
  long n = 1;
  for (const long c : cells) n *= c;
  return ElasticModel<dim>::voxel_grid(cells, Vec<dim>::Zero(), Vec<dim>::Ones(),
                                       random_moduli<dim>(static_cast<std::size_t>(n)), poisson_ratio);
}

// One model made twice by `make`, both under add_conditions: `serial` solved on each rank (CHOLMOD),
// `spread` with its solves over the ranks (distribute_solves). solve() gives the serial and the spread
// solution of the same point constraints (the spread one to a relative tolerance of 1e-13).
struct SerialAndSpread {
  template <class Make>
  explicit SerialAndSpread(Make make) : serial(make()), spread(make()) {
    add_conditions(serial);
    add_conditions(spread);
    distribute_solves(spread, MPI_COMM_WORLD);
  }
  std::pair<Solution<3>, Solution<3>> solve(const std::vector<PointConstraint<3>>& points) {
    SolverOptions direct, tight;
    direct.type = SolverOptions::Type::direct;
    tight.tolerance = 1e-13;
    Solution<3> ref = serial.solve(points, direct);
    return {std::move(ref), spread.solve(points, tight)};
  }
  ElasticModel<3> serial, spread;
};

// The conditions of add_conditions on `model`, then its distributed solve against the serial one.
template <int dim>
void compare_under_conditions(ElasticModel<dim> model, const std::string& method = "cg+amg") {
  add_conditions(model);
  compare(model, method);
}
}  // namespace

TEST(Distributed, SimplexP1_3D) {
  const auto mesh = test::kuhn_box<3>({{10, 10, 10}}, {{0, 0, 0}}, {{1, 1, 1}});
  compare_under_conditions(ElasticModel<3>(mesh, random_moduli<3>(mesh.n_cells()), 0.35, 1));
}

TEST(Distributed, SimplexP2_3D) {
  const auto mesh = test::kuhn_box<3>({{5, 5, 5}}, {{0, 0, 0}}, {{1, 1, 1}});
  compare_under_conditions(ElasticModel<3>(mesh, random_moduli<3>(mesh.n_cells()), 0.45, 2));
}

TEST(Distributed, SimplexP1_2D) {
  const auto mesh = test::kuhn_box<2>({{30, 30}}, {{0, 0}}, {{1, 1}});
  compare_under_conditions(ElasticModel<2>(mesh, random_moduli<2>(mesh.n_cells()), 0.3, 1));
}

// A support along rotated axes (DirichletBC::axes; constraint lines with entries, the serial path is
// checked against the rotated body in tests/fem): the face x = 0 slides in the plane normal to a
// tilted direction, the face x = 1 is pushed along it; the bottom is fixed.
TEST(Distributed, SlidingSupportAlongRotatedAxesP1_3D) {
  const auto mesh = test::kuhn_box<3>({{8, 8, 8}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, random_moduli<3>(mesh.n_cells()), 0.3, 1);
  const Vec<3> lo = Vec<3>::Zero(), hi = Vec<3>::Ones();
  const double c = std::cos(0.5), s = std::sin(0.5);
  Eigen::Matrix3d axes;
  axes << c, -s, 0, s, c, 0, 0, 0, 1;
  DirichletBC<3> slide;
  slide.region = box_face_region<3>(lo, hi, 0, false, 1e-9);
  slide.components = {{true, false, false}};
  slide.axes = axes;
  model.add_dirichlet(slide);
  DirichletBC<3> push = slide;
  push.region = box_face_region<3>(lo, hi, 0, true, 1e-9);
  push.value[0] = -0.02;
  model.add_dirichlet(push);
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(lo, hi, 2, false, 1e-9);
  model.add_dirichlet(fixed);
  model.set_body_force(Vec<3>(0.1, 0.0, -0.1));
  compare(model);
}

TEST(Distributed, VoxelModel3D) {
  compare_under_conditions(random_voxel_model<3>({{12, 10, 8}}, 0.4), "cg+matrix-free multigrid");
}

// Grid sizes divisible by 4 (coarse p4est grid refined twice) and odd sizes (no refinement), 2D.
TEST(Distributed, VoxelModel3DRefinedCoarseGrid) {
  compare_under_conditions(random_voxel_model<3>({{16, 8, 12}}, 0.3), "cg+matrix-free multigrid");
}

// Five multigrid levels (32³, coarse grid one cell) with moduli spanning 1 to 8 per voxel.
TEST(Distributed, VoxelModel3DMultigridLevels) {
  compare_under_conditions(random_voxel_model<3>({{32, 32, 32}}, 0.3), "cg+matrix-free multigrid");
}

// A support along rotated axes (constraint lines with entries) on a voxel grid: CG + AMG, not multigrid.
TEST(Distributed, VoxelModel3DRotatedSupportUsesAmg) {
  auto model = random_voxel_model<3>({{8, 8, 8}}, 0.3);
  const Vec<3> lo = Vec<3>::Zero(), hi = Vec<3>::Ones();
  DirichletBC<3> slide;
  slide.region = box_face_region<3>(lo, hi, 0, false, 1e-9);
  slide.components = {{true, false, false}};
  const double c = std::cos(0.5), s = std::sin(0.5);
  slide.axes << c, -s, 0, s, c, 0, 0, 0, 1;
  model.add_dirichlet(slide);
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(lo, hi, 2, false, 1e-9);
  model.add_dirichlet(fixed);
  model.set_body_force(Vec<3>(0.1, 0.0, -0.1));
  compare(model, "cg+amg");
}

TEST(Distributed, VoxelModel2DOddSizes) { compare_under_conditions(random_voxel_model<2>({{9, 7}}, 0.3)); }

TEST(Distributed, SingularThrowsOnEveryRank) {
  const auto mesh = test::kuhn_box<3>({{3, 3, 3}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3, 1);
  EXPECT_THROW(solve_distributed(model, MPI_COMM_WORLD), std::runtime_error);
}

// The fully distributed simplex mesh: the cells the ranks own together hold every cell once, each rank
// some (METIS splits the cube into parts of comparable size).
TEST(Distributed, OwnedCellsOfASimplexModelPartitionItsCells) {
  const auto mesh = test::kuhn_box<3>({{6, 6, 6}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, random_moduli<3>(mesh.n_cells()), 0.3, 1);
  add_conditions(model);
  const std::vector<std::size_t> mine = owned_cells(model, MPI_COMM_WORLD);
  const unsigned ranks = dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD);
  EXPECT_GT(mine.size(), mesh.n_cells() / (3 * ranks));
  std::vector<double> times_owned(mesh.n_cells(), 0.0);
  for (const std::size_t c : mine) times_owned.at(c) += 1.0;
  dealii::Utilities::MPI::sum(dealii::ArrayView<const double>(times_owned.data(), times_owned.size()),
                              MPI_COMM_WORLD,
                              dealii::ArrayView<double>(times_owned.data(), times_owned.size()));
  for (std::size_t c = 0; c < times_owned.size(); ++c) ASSERT_EQ(times_owned[c], 1.0) << "cell " << c;
  // a solve reads the same partition
  solve_distributed(model, MPI_COMM_WORLD);
  EXPECT_EQ(owned_cells(model, MPI_COMM_WORLD), mine);
}

// A mesh with fewer cells than ranks cannot be split: every rank gets the same clear error.
TEST(Distributed, FewerCellsThanRanksIsRefusedOnEveryRank) {
  SimplexMesh<3> tet;
  tet.points = {Vec<3>(0, 0, 0), Vec<3>(1, 0, 0), Vec<3>(0, 1, 0), Vec<3>(0, 0, 1)};
  tet.cells = {{{0, 1, 2, 3}}};
  ElasticModel<3> model(tet, {1.0}, 0.3, 1);
  add_conditions(model);
  try {
    solve_distributed(model, MPI_COMM_WORLD);
    ADD_FAILURE() << "no error for a 1-cell mesh on 2 ranks";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fewer than the 2 MPI ranks"), std::string::npos) << e.what();
  }
}

// distribute_solves: the needle's rows (one point held exactly, one averaged over samples with a series
// compliance) on two ranks vs the serial Schur solve of the same model (CHOLMOD): displacements and
// point forces to 1e-8, twice (the second solve reuses the cached columns and moves the points).
TEST(Distributed, PointConstraintsThroughDistributedColumns) {
  const auto mesh = test::kuhn_box<3>({{8, 8, 8}}, {{0, 0, 0}}, {{1, 1, 1}});
  SerialAndSpread models([&] { return ElasticModel<3>(mesh, random_moduli<3>(mesh.n_cells()), 0.35, 1); });
  ElasticModel<3>&serial = models.serial, &spread = models.spread;
  PointConstraint<3> tip(Vec<3>(0.43, 0.51, 0.47), Vec<3>(0.01, -0.02, 0.005));
  PointConstraint<3> band(Vec<3>(0.3, 0.52, 0.5), Vec<3>(0.0, 0.01, 0.0));
  for (int q = 0; q < 8; ++q) {
    const double a = 0.25 * M_PI * q;
    band.offsets.push_back(Vec<3>(0.0, 0.1 * std::cos(a), 0.1 * std::sin(a)));
    band.weights.push_back(1.0);
  }
  band.compliance = Vec<3>(0.02, 0.03, 0.03);
  for (int pass = 0; pass < 2; ++pass) {
    const auto [ref, sol] = models.solve({tip, band});
    EXPECT_NE(sol.stats.method.find("mpi"), std::string::npos) << sol.stats.method;
    for (std::size_t k = 0; k < 2; ++k) {
      ASSERT_GT(ref.point_force[k].norm(), 0);
      EXPECT_LT((sol.point_force[k] - ref.point_force[k]).norm(), 1e-8 * ref.point_force[k].norm()) << k;
    }
    // with the energy, stresses and reactions each rank computes on its own cells
    expect_same_fields(ref, sol, 1e-8);
    tip.position[0] += 0.05;
  }
  // No rank builds the serial model: each holds its part of the distributed mesh (owned and ghost
  // cells) and no serial stiffness matrix, while the serial model holds the whole mesh, K and K_full.
  std::cout << "[rank " << dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD)
            << "] model bytes: serial " << serial.memory_consumption() << ", over the ranks "
            << spread.memory_consumption() << "; cells held: serial " << serial.cells_held()
            << ", over the ranks " << spread.cells_held() << " of " << mesh.n_cells() << "\n";
  EXPECT_EQ(serial.cells_held(), mesh.n_cells());
  EXPECT_GT(spread.cells_held(), 0u);
  EXPECT_LT(spread.cells_held(), 0.8 * mesh.n_cells());
  EXPECT_LT(spread.memory_consumption(), 0.6 * serial.memory_consumption());
}

// The same random points and mesh edges on every rank: points inside the unit box and one outside.
std::vector<Vec<3>> sample_points() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Vec<3>> at(40);
  for (auto& x : at) x = Vec<3>(U(rng), U(rng), U(rng));
  at.push_back(Vec<3>(1.5, 0.5, 0.5));
  return at;
}

// sample() and edge_midpoint_displacement() of a P2 model whose solves run over the ranks (stencils
// from the rank owning each point's cell) vs the serial model: to 1e-8 of the largest displacement,
// the point outside the mesh reported outside by both; and the DoF count before any solve.
TEST(Distributed, P2SamplesAndEdgeMidpointsMatchTheSerialModel) {
  const auto mesh = test::kuhn_box<3>({{4, 4, 4}}, {{0, 0, 0}}, {{1, 1, 1}});
  SerialAndSpread models([&] { return ElasticModel<3>(mesh, random_moduli<3>(mesh.n_cells()), 0.3, 2); });
  ElasticModel<3>&serial = models.serial, &spread = models.spread;
  EXPECT_EQ(spread.n_dofs(), serial.n_dofs());
  EXPECT_EQ(spread.cells_held(), 0u);  // nothing built before the first solve
  PointConstraint<3> tip(Vec<3>(0.41, 0.52, 0.46), Vec<3>(0.01, -0.02, 0.005));
  const auto [ref, sol] = models.solve({tip});
  expect_same_fields(ref, sol, 1e-8);
  EXPECT_LT((sol.point_force[0] - ref.point_force[0]).norm(), 1e-8 * ref.point_force[0].norm());
  double scale = 0;
  for (const auto& u : ref.vertex_displacement) scale = std::max(scale, u.norm());
  PointSample in_serial, in_spread;
  const auto at = sample_points();
  const auto a = serial.sample(at, &in_serial), b = spread.sample(at, &in_spread);
  EXPECT_EQ(in_spread.inside, in_serial.inside);
  EXPECT_EQ(in_spread.n_outside, 1u);
  for (std::size_t i = 0; i < at.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), 1e-8 * scale) << i;
  std::vector<std::array<int, 2>> edges;
  for (std::size_t c = 0; c < mesh.cells.size(); c += 7)
    edges.push_back({{mesh.cells[c][0], mesh.cells[c][2]}});
  const auto ea = serial.edge_midpoint_displacement(edges), eb = spread.edge_midpoint_displacement(edges);
  for (std::size_t e = 0; e < edges.size(); ++e) EXPECT_LT((ea[e] - eb[e]).norm(), 1e-8 * scale) << e;
  EXPECT_THROW(spread.edge_midpoint_displacement({{{0, static_cast<int>(mesh.points.size()) - 1}}}),
               std::invalid_argument);
}

// A voxel model with a point constraint whose solves run over the ranks (p4est grid, no serial grid on
// any rank) vs the serial model: point force and samples to 1e-8.
TEST(Distributed, VoxelModelWithAPointConstraintMatchesTheSerialModel) {
  SerialAndSpread models([] { return random_voxel_model<3>({{6, 5, 4}}, 0.3); });
  ElasticModel<3>&serial = models.serial, &spread = models.spread;
  PointConstraint<3> tip(Vec<3>(0.45, 0.55, 0.5), Vec<3>(0.0, 0.01, -0.01));
  const auto [ref, sol] = models.solve({tip});
  EXPECT_NE(sol.stats.method.find("mpi"), std::string::npos) << sol.stats.method;
  expect_same_fields(ref, sol, 1e-8);
  EXPECT_LT((sol.point_force[0] - ref.point_force[0]).norm(), 1e-8 * ref.point_force[0].norm());
  double scale = 0;
  for (const auto& u : ref.vertex_displacement) scale = std::max(scale, u.norm());
  const auto at = sample_points();
  const auto a = serial.sample(at), b = spread.sample(at);
  for (std::size_t i = 0; i < at.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), 1e-8 * scale) << i;
  EXPECT_LT(spread.cells_held(), 6u * 5u * 4u);
}

// Tests for fem/include/vim/fem/elasticity.hpp against independent truth: patch tests (linear
// fields reproduced exactly), the two-material bar in series (σ(L1/E1 + L2/E2)), a near-incompressible
// cantilever vs Euler–Bernoulli, fast (Schur, cached) vs monolithic point constraints, and bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vim/fem/distributed.hpp>
#include <vim/fem/elasticity.hpp>

#include "box_conditions.hpp"
#include "box_mesh.hpp"
#include "needle_path_rows.hpp"
#include "solutions_agree.hpp"

using namespace vim;
using namespace vim::fem;
using ::testing::HasSubstr;

namespace {

template <int dim>
Region<dim> boundary_of_unit_box(double tol = 1e-12) {
  return {"boundary", [tol](const Vec<dim>& x) {
            for (int d = 0; d < dim; ++d)
              if (std::abs(x[d]) < tol || std::abs(x[d] - 1.0) < tol) return true;
            return false;
          }};
}

// Unit-box Kuhn mesh with interior nodes moved randomly (still valid), so the patch is irregular.
template <int dim>
SimplexMesh<dim> perturbed_unit_box(int n, unsigned seed) {
  std::array<int, dim> cells;
  std::array<double, dim> lo, hi;
  cells.fill(n), lo.fill(0.0), hi.fill(1.0);
  auto mesh = test::kuhn_box<dim>(cells, lo, hi);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-0.2 / n, 0.2 / n);
  for (auto& p : mesh.points) {
    bool interior = true;
    for (int d = 0; d < dim; ++d) interior = interior && p[d] > 1e-9 && p[d] < 1 - 1e-9;
    if (interior)
      for (int d = 0; d < dim; ++d) p[d] += U(rng);
  }
  return mesh;
}

template <int dim>
void patch_test(unsigned degree) {
  const auto mesh = perturbed_unit_box<dim>(dim == 2 ? 6 : 3, 7 + degree);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 1.0), P(1.0, 5.0);
  // one modulus: with per-cell moduli a linear field is not in equilibrium (traction jumps)
  const std::vector<double> E(mesh.n_cells(), P(rng));
  const double nu = 0.3;
  Eigen::Matrix<double, dim, dim> A;
  Vec<dim> b;
  for (int i = 0; i < dim; ++i) {
    b[i] = U(rng);
    for (int j = 0; j < dim; ++j) A(i, j) = 0.01 * U(rng);
  }
  ElasticModel<dim> model(mesh, E, nu, degree);
  DirichletBC<dim> bc;
  bc.region = boundary_of_unit_box<dim>();
  bc.function = [&](const Vec<dim>& x) -> Vec<dim> { return A * x + b; };
  model.add_dirichlet(bc);
  const auto sol = model.solve();
  double umax = 0;
  for (std::size_t i = 0; i < mesh.n_points(); ++i) umax = std::max(umax, (A * mesh.points[i] + b).norm());
  for (std::size_t i = 0; i < mesh.n_points(); ++i)
    ASSERT_LT((sol.vertex_displacement[i] - (A * mesh.points[i] + b)).norm(), 1e-11 * umax) << "vertex " << i;
  const Eigen::Matrix<double, dim, dim> eps = 0.5 * (A + A.transpose());
  double energy = 0.0;
  for (std::size_t j = 0; j < mesh.n_cells(); ++j) {
    ASSERT_LT((sol.cell_strain[j] - eps).norm(), 1e-10 * eps.norm()) << "cell " << j;
    // textbook Lamé parameters, not the code's lame_parameters
    const double lambda = E[j] * nu / ((1 + nu) * (1 - 2 * nu)), mu = E[j] / (2 * (1 + nu));
    Eigen::Matrix<double, dim, dim> sigma =
        2 * mu * eps + lambda * eps.trace() * Eigen::Matrix<double, dim, dim>::Identity();
    ASSERT_LT((sol.cell_stress[j] - sigma).norm(), 1e-9 * sigma.norm()) << "cell " << j;
    energy += 0.5 * (sigma.array() * eps.array()).sum() * std::abs(signed_volume(mesh, j));
  }
  EXPECT_NEAR(sol.strain_energy, energy, 1e-10 * energy);
  // interior points (not nodes): for P2 these exercise the quadratic basis
  std::vector<Vec<dim>> pts;
  std::uniform_real_distribution<double> I(0.05, 0.95);
  for (int k = 0; k < 20; ++k) {
    Vec<dim> x;
    for (int d = 0; d < dim; ++d) x[d] = I(rng);
    pts.push_back(x);
  }
  PointSample info;
  const auto vals = model.sample(pts, &info);
  EXPECT_EQ(info.n_outside, 0u);
  for (std::size_t k = 0; k < pts.size(); ++k) EXPECT_LT((vals[k] - (A * pts[k] + b)).norm(), 1e-11 * umax);
}

}  // namespace

TEST(PatchTest, P1_2D) { patch_test<2>(1); }
TEST(PatchTest, P2_2D) { patch_test<2>(2); }
TEST(PatchTest, P1_3D) { patch_test<3>(1); }
TEST(PatchTest, P2_3D) { patch_test<3>(2); }

// ---------------------------------------------------------------------------------------------
// Layered bar, ν = 0, lateral faces sliding: u_tip = σ (L1/E1 + L2/E2), reaction = −σ A.

namespace {
constexpr double L1 = 0.6, L2 = 1.4, E1 = 3.0, E2 = 11.0, SIGMA = 0.25;

template <int dim>
void bar_conditions(ElasticModel<dim>& model, const Vec<dim>& lo, const Vec<dim>& hi) {
  for (int d = 0; d < dim; ++d) {
    DirichletBC<dim> bc;
    bc.region = box_face_region<dim>(lo, hi, d, false, 1e-9);
    bc.components = DirichletBC<dim>::filled(false);
    bc.components[d] = true;
    model.add_dirichlet(bc);
  }
  SurfaceLoad<dim> load;
  load.region = box_face_region<dim>(lo, hi, 0, true, 1e-9);
  load.traction[0] = SIGMA;
  model.add_surface_load(load);
}

template <int dim>
void check_bar(const ElasticModel<dim>& model, const Solution<dim>& sol, double area) {
  const double expected = SIGMA * (L1 / E1 + L2 / E2);
  int tip = 0;
  for (std::size_t i = 0; i < model.vertices().size(); ++i) {
    const double x = model.vertices()[i][0];
    const double exact_x = x <= L1 ? SIGMA * x / E1 : SIGMA * (L1 / E1 + (x - L1) / E2);
    EXPECT_NEAR(sol.vertex_displacement[i][0], exact_x, 1e-10 * expected) << "vertex " << i;
    for (int d = 1; d < dim; ++d) EXPECT_NEAR(sol.vertex_displacement[i][d], 0.0, 1e-10 * expected);
    if (std::abs(x - (L1 + L2)) < 1e-12) {
      ++tip;
      EXPECT_NEAR(sol.vertex_displacement[i][0], expected, 1e-10 * expected);
    }
  }
  EXPECT_GT(tip, 0);
  EXPECT_NEAR(sol.dirichlet_reaction[0][0], -SIGMA * area, 1e-10 * SIGMA * area);
  // energy = ½ F u_tip
  EXPECT_NEAR(sol.strain_energy, 0.5 * SIGMA * area * expected, 1e-10 * SIGMA * area * expected);
}
}  // namespace

TEST(LayeredBar, SimplexConformingInterface3D) {
  std::array<std::vector<double>, 3> c;
  c[0] = test::linspace(0, L1, 3);
  const auto right = test::linspace(L1, L1 + L2, 5);
  c[0].insert(c[0].end(), right.begin() + 1, right.end());
  c[1] = test::linspace(0, 0.5, 2);
  c[2] = test::linspace(0, 0.8, 2);
  const auto mesh = test::kuhn_mesh<3>(c);
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = centroid<3>(cell_points(mesh, j))[0] < L1 ? E1 : E2;
  for (unsigned degree : {1u, 2u}) {
    ElasticModel<3> model(mesh, E, 0.0, degree);
    bar_conditions<3>(model, Vec<3>(0, 0, 0), Vec<3>(L1 + L2, 0.5, 0.8));
    check_bar<3>(model, model.solve(), 0.5 * 0.8);
  }
}

TEST(LayeredBar, Simplex2D) {
  std::array<std::vector<double>, 2> c;
  c[0] = {0.0, 0.3, L1, 1.0, 1.5, L1 + L2};
  c[1] = test::linspace(0, 0.7, 3);
  const auto mesh = test::kuhn_mesh<2>(c);
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = centroid<2>(cell_points(mesh, j))[0] < L1 ? E1 : E2;
  ElasticModel<2> model(mesh, E, 0.0, 1);
  bar_conditions<2>(model, Vec<2>(0, 0), Vec<2>(L1 + L2, 0.7));
  check_bar<2>(model, model.solve(), 0.7);
}

// The bar as a voxel image: element moduli through element_modulus (Eq. 15) from voxel-centre
// means computed by brute force, with a unit scale (image in Pa, model in kPa).
TEST(LayeredBar, FromVoxelImageThroughElementModulus) {
  const int nx = 20, ny = 4, nz = 4;  // voxel size 0.1 × 0.125 × 0.2
  const double Lx = L1 + L2, Ly = 0.5, Lz = 0.8;
  std::vector<double> image(nx * ny * nz);
  auto centre = [&](int i, int j, int k) {
    return Vec<3>((i + 0.5) * Lx / nx, (j + 0.5) * Ly / ny, (k + 0.5) * Lz / nz);
  };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        image[i + nx * (j + ny * k)] = 1000.0 * (centre(i, j, k)[0] < L1 ? E1 : E2);
  // mesh nodes on every second voxel boundary: the interface x = L1 = 6 voxels is a node plane
  std::array<int, 3> cells{{10, 2, 2}};
  const auto mesh = test::kuhn_box<3>(cells, {{0, 0, 0}}, {{Lx, Ly, Lz}});
  std::vector<double> mean(mesh.n_cells());
  for (std::size_t t = 0; t < mesh.n_cells(); ++t) {
    const auto x = cell_points(mesh, t);
    Eigen::Matrix3d T;
    for (int d = 0; d < 3; ++d) T.col(d) = x[d + 1] - x[0];
    const Eigen::Matrix3d Ti = T.inverse();
    double s = 0;
    int n = 0;
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const Eigen::Vector3d l = Ti * (centre(i, j, k) - x[0]);
          if (l.minCoeff() >= -1e-12 && l.sum() <= 1 + 1e-12) s += image[i + nx * (j + ny * k)], ++n;
        }
    ASSERT_GT(n, 0) << "tet " << t << " encloses no voxel centre";
    mean[t] = s / n;
  }
  const auto E = element_modulus(mean, 1e-3);
  ElasticModel<3> model(mesh, E, 0.0, 1);
  bar_conditions<3>(model, Vec<3>(0, 0, 0), Vec<3>(Lx, Ly, Lz));
  check_bar<3>(model, model.solve(), Ly * Lz);
}

TEST(LayeredBar, VoxelGridModel) {
  const std::array<long, 3> cells{{20, 3, 2}};
  std::vector<double> E(20 * 3 * 2);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 20; ++i) E[i + 20 * (j + 3 * k)] = (i + 0.5) * 0.1 < L1 ? E1 : E2;
  auto model = ElasticModel<3>::voxel_grid(cells, Vec<3>(0, 0, 0), Vec<3>(L1 + L2, 0.5, 0.8), E, 0.0);
  EXPECT_EQ(model.n_cells(), 120u);
  bar_conditions<3>(model, Vec<3>(0, 0, 0), Vec<3>(L1 + L2, 0.5, 0.8));
  check_bar<3>(model, model.solve(), 0.5 * 0.8);
}

// Voxel ordering: moduli vary along y only (axis 1); a bar loaded along y must see them in order.
TEST(LayeredBar, VoxelGridOrderingAlongSecondAxis) {
  const std::array<long, 2> cells{{2, 10}};
  std::vector<double> E(20);
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 2; ++i) E[i + 2 * j] = 1.0 + j;
  auto model = ElasticModel<2>::voxel_grid(cells, Vec<2>(0, 0), Vec<2>(1, 5), E, 0.0);
  for (int d = 0; d < 2; ++d) {
    DirichletBC<2> bc;
    bc.region = box_face_region<2>(Vec<2>(0, 0), Vec<2>(1, 5), d, false, 1e-9);
    bc.components = {{d == 0, d == 1}};
    model.add_dirichlet(bc);
  }
  SurfaceLoad<2> load;
  load.region = box_face_region<2>(Vec<2>(0, 0), Vec<2>(1, 5), 1, true, 1e-9);
  load.pressure = -2.0;  // negative pressure = tension along +y (outward normal)
  model.add_surface_load(load);
  const auto sol = model.solve();
  for (std::size_t i = 0; i < model.vertices().size(); ++i) {
    const double y = model.vertices()[i][1];
    double exact = 0;
    for (int j = 0; j < 10; ++j) exact += 2.0 * std::clamp(y - 0.5 * j, 0.0, 0.5) / (1.0 + j);
    EXPECT_NEAR(sol.vertex_displacement[i][1], exact, 1e-10);
  }
}

// ---------------------------------------------------------------------------------------------
// ν = 0.49 cantilever, clamped at x = 0, shear load P at x = L: EB deflection P L³ / (3 E I).

namespace {
double cantilever_tip(unsigned degree, int nx, int nyz) {
  const double L = 10.0, h = 1.0, E = 1000.0, P = 1.0;
  const auto mesh = test::kuhn_box<3>({{nx, nyz, nyz}}, {{0, 0, 0}}, {{L, h, h}});
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), E), 0.49, degree);
  DirichletBC<3> clamp;
  clamp.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(L, h, h), 0, false, 1e-9);
  model.add_dirichlet(clamp);
  SurfaceLoad<3> load;
  load.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(L, h, h), 0, true, 1e-9);
  load.traction[2] = -P / (h * h);
  model.add_surface_load(load);
  const auto sol = model.solve();
  const double I = h * h * h * h / 12.0, eb = P * L * L * L / (3 * E * I);
  const auto tip = model.sample({Vec<3>(L, 0.5 * h, 0.5 * h)});
  return -tip[0][2] / eb;
}
}  // namespace

TEST(Cantilever, NearIncompressibleP2ConvergesP1Locks) {
  const double p1 = cantilever_tip(1, 20, 2), p2 = cantilever_tip(2, 20, 2);
  const double p1_fine = cantilever_tip(1, 40, 4);
  std::printf("cantilever nu=0.49 tip/EB: P1(20x2x2) %.4f  P1(40x4x4) %.4f  P2(20x2x2) %.4f\n", p1, p1_fine,
              p2);
  EXPECT_GT(p2, 0.93);
  EXPECT_LT(p2, 1.05);
  EXPECT_LT(p1, 0.5);  // locking: far too stiff
  EXPECT_LT(p1_fine, 0.8);
  EXPECT_GT(p2 / p1, 2.0);
}

// ---------------------------------------------------------------------------------------------
// Embedded point constraints: fast path (factorise once, cached K⁻¹cᵀ, Schur) vs monolithic.

namespace {
template <int dim>
ElasticModel<dim> needle_block(unsigned degree, SimplexMesh<dim>* mesh_out = nullptr) {
  std::array<int, dim> cells;
  std::array<double, dim> lo, hi;
  cells.fill(dim == 2 ? 10 : 5), lo.fill(0.0), hi.fill(1.0);
  const auto mesh = test::kuhn_box<dim>(cells, lo, hi);
  std::vector<double> E(mesh.n_cells());
  for (std::size_t j = 0; j < E.size(); ++j) E[j] = 1.0 + 3.0 * centroid<dim>(cell_points(mesh, j))[0];
  ElasticModel<dim> model(mesh, E, 0.45, degree);
  vim::test::hold_and_push(model, false, 0.01);
  if (mesh_out) *mesh_out = mesh;
  return model;
}

template <int dim>
void fast_vs_monolithic(unsigned degree) {
  auto model = needle_block<dim>(degree);
  std::vector<PointConstraint<dim>> points;
  for (int step = 0; step < 6; ++step) {
    // the needle advances along the top-down diagonal; passed points stick and move with the shaft
    PointConstraint<dim> p;
    p.position = Vec<dim>::Constant(0.5);
    p.position[dim - 1] = 0.95 - 0.18 * step;  // the last ones sit in cells touching the fixed face
    p.position[0] = 0.31 + 0.013 * step;
    points.push_back(p);
    for (auto& q : points)
      if (q.position[dim - 1] > 0.01) q.displacement[dim - 1] = -0.01 * (step + 1);
    if (step == 3)
      points[0].components = DirichletBC<dim>::filled(false), points[0].components[dim - 1] = true;
    if (step == 2)
      points.push_back({Vec<dim>::Constant(0.0), Vec<dim>::Constant(0.0)});  // on the fixed corner: void row
    const auto fast = model.solve(points);
    const auto ref = model.solve_monolithic(points);
    vim::test::expect_solutions_agree<dim>(fast, ref, 1e-8, "step " + std::to_string(step));
    if (::testing::Test::HasFatalFailure()) return;
    double fmax = 0;
    for (const auto& f : ref.point_force) fmax = std::max(fmax, f.norm());
    // the constraints hold at the embedded points
    std::vector<Vec<dim>> pos;
    for (const auto& q : points) pos.push_back(q.position);
    const auto at = model.sample(pos);
    for (std::size_t k = 0; k < points.size(); ++k)
      for (int c = 0; c < dim; ++c)
        if (points[k].components[c]) {
          EXPECT_NEAR(at[k][c], points[k].displacement[c], 1e-10)
              << "step " << step << " point " << k << " comp " << c;
        }
    // global equilibrium: reactions + point forces + body force = 0 (per component)
    Vec<dim> total = Vec<dim>::Constant(-0.1);  // body force × unit volume
    for (const auto& r : fast.dirichlet_reaction) total += r;
    for (const auto& f : fast.point_force) total += f;
    EXPECT_LT(total.norm(), 1e-9 * (fmax + 0.1)) << "step " << step;
  }
}
}  // namespace

TEST(PointConstraints, FastPathMatchesMonolithicP1_3D) { fast_vs_monolithic<3>(1); }
TEST(PointConstraints, FastPathMatchesMonolithicP2_2D) { fast_vs_monolithic<2>(2); }

// Truth: the monolithic saddle-point solve of each subset. Every row a path can use is precomputed in
// one batch (averaged rows with a series compliance, as a finite-radius needle's stations, and point
// rows); a second precomputation finds them all cached, and the solves of growing subsets (a needle
// advancing, its stations joining) agree with the monolithic solve of the same rows.
namespace {
template <int dim>
void precomputed_vs_monolithic(unsigned degree) {
  auto model = needle_block<dim>(degree);
  // Band rows (a finite-radius needle's stations) and point rows alternating.
  const std::vector<PointConstraint<dim>> path = vim::test::needle_path_rows<dim>(5, 0.15, 0.5, 0.0);
  EXPECT_EQ(model.precompute(path), static_cast<unsigned>(dim * path.size()));
  EXPECT_EQ(model.precompute(path), 0u);  // all cached
  std::vector<PointConstraint<dim>> active;
  for (std::size_t j = 0; j < path.size(); ++j) {
    active.push_back(path[j]);
    for (auto& q : active) q.displacement[dim - 1] -= 0.01;
    vim::test::expect_solutions_agree<dim>(model.solve(active), model.solve_monolithic(active), 1e-8,
                                           "step " + std::to_string(j), false);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_EQ(model.precompute(path), 0u);  // the solves added nothing
}
}  // namespace

TEST(PointConstraints, PrecomputedRowsMatchMonolithicP2_3D) { precomputed_vs_monolithic<3>(2); }
TEST(PointConstraints, PrecomputedRowsMatchMonolithicP1_2D) { precomputed_vs_monolithic<2>(1); }

// The sign convention: pulling a point in +z needs a force on the body in +z.
TEST(PointConstraints, ForceSignAndLinearity) {
  auto model = needle_block<3>(1);
  PointConstraint<3> p{Vec<3>(0.5, 0.5, 0.5), Vec<3>(0, 0, 0.02)};
  const auto a = model.solve({p});
  p.displacement *= 2;
  const auto b = model.solve({p});
  EXPECT_GT(a.point_force[0][2], 0.0);
  // linearity: force(2δ) − force(δ) = force(δ) − force(0)
  const auto z = model.solve({PointConstraint<3>{Vec<3>(0.5, 0.5, 0.5), Vec<3>::Zero()}});
  EXPECT_NEAR(b.point_force[0][2] - a.point_force[0][2], a.point_force[0][2] - z.point_force[0][2],
              1e-9 * std::abs(a.point_force[0][2]));
}

// A needle steps more finely than the mesh: several collinear points in one P1 element are linearly
// dependent (P1 is affine along the line). With consistent displacements (rigid shaft motion) the
// dependent rows are dropped, both paths agree, and every point still moves as prescribed.
TEST(PointConstraints, RedundantCollinearPointsInOneElement) {
  auto model = needle_block<3>(1);
  std::vector<PointConstraint<3>> pts;
  for (int k = 0; k < 6; ++k) pts.push_back({Vec<3>(0.503, 0.497, 0.78 - 0.03 * k), Vec<3>(0.001, 0, -0.01)});
  const auto fast = model.solve(pts);
  const auto ref = model.solve_monolithic(pts);
  EXPECT_GT(fast.stats.dependent_rows_dropped, 0u);
  EXPECT_EQ(fast.stats.dependent_rows_dropped, ref.stats.dependent_rows_dropped);
  EXPECT_EQ(fast.stats.constraint_rows + fast.stats.dependent_rows_dropped, 18u);
  double umax = 0;
  for (const auto& u : ref.vertex_displacement) umax = std::max(umax, u.norm());
  for (std::size_t i = 0; i < ref.vertex_displacement.size(); ++i)
    ASSERT_LT((fast.vertex_displacement[i] - ref.vertex_displacement[i]).norm(), 1e-8 * umax);
  for (std::size_t k = 0; k < pts.size(); ++k)
    EXPECT_LT((fast.point_force[k] - ref.point_force[k]).norm(), 1e-8);
  std::vector<Vec<3>> pos;
  for (const auto& p : pts) pos.push_back(p.position);
  const auto at = model.sample(pos);
  for (std::size_t k = 0; k < pts.size(); ++k) EXPECT_LT((at[k] - pts[k].displacement).norm(), 1e-10);
  // bending the shaft inside one element is not representable: conflicting rows are reported
  pts[3].displacement[0] = 0.01;
  EXPECT_THROW(model.solve(pts), std::runtime_error);
}

// A needle path along a line of element edges, sampled every 0.57 edge lengths: each point
// interpolates between the two vertices of its edge, so the rows of a chain are dependent up to the
// round-off of the barycentric weights. The ordered pivots then need not vanish (cancellation, depending
// on the processor's rounding), while the reciprocal condition of the rows' Schur complement falls
// geometrically with the chain's length (~1e-4 at 4 points, ~1e-18 at 30). A short chain solves exactly;
// a long one is reported as dependent on any processor: its forces and the displacements between the
// points would be round-off noise (a 2D pipeline run moved the vertices on the path by up to 0.1 mm
// against 1e-9 for the points themselves).
TEST(PointConstraints, LongChainAlongElementEdgesIsReportedAsDependent) {
  const int n = 40;
  const auto mesh = test::kuhn_box<2>({{n, n}}, {{0.0, 0.0}}, {{1.0, 1.0}});
  ElasticModel<2> model(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3, 1);
  DirichletBC<2> fixed;
  fixed.region = box_face_region<2>(Vec<2>(0, 0), Vec<2>(1, 1), 0, true, 1e-9);
  model.add_dirichlet(fixed);
  auto chain = [&](int points) {  // along the grid line y = 0.5 from x = 0, pulled along x
    std::vector<PointConstraint<2>> pts;
    for (int i = 0; i < points; ++i) pts.push_back({Vec<2>(0.57 * i / n, 0.5), Vec<2>(-0.01, 0.0)});
    return pts;
  };
  const auto shortc = chain(4);
  const auto s = model.solve(shortc);
  EXPECT_EQ(s.stats.constraint_rows + s.stats.dependent_rows_dropped, 8u);
  std::vector<Vec<2>> pos;
  for (const auto& p : shortc) pos.push_back(p.position);
  const auto at = model.sample(pos);
  for (std::size_t k = 0; k < shortc.size(); ++k) EXPECT_LT((at[k] - shortc[k].displacement).norm(), 1e-10);
  try {
    model.solve(chain(30));
    ADD_FAILURE() << "a chain of 30 points along element edges was solved";
  } catch (const DependentPointConstraints& e) {
    EXPECT_THAT(e.what(), HasSubstr("nearly dependent"));
    EXPECT_THAT(e.what(), HasSubstr("reciprocal condition"));
  }
}

TEST(Sample, CountsPointsOutside) {
  auto model = needle_block<3>(1);
  model.solve();
  PointSample info;
  const auto v =
      model.sample({Vec<3>(0.5, 0.5, 0.5), Vec<3>(2, 0, 0), Vec<3>(1, 1, 1), Vec<3>(-0.1, 0.5, 0.5)}, &info);
  EXPECT_EQ(info.n_outside, 2u);
  EXPECT_EQ(info.inside, (std::vector<bool>{true, false, true, false}));
  EXPECT_EQ(v[1], Vec<3>::Zero());
  EXPECT_NE(v[0], Vec<3>::Zero());
}

// ---------------------------------------------------------------------------------------------
// Bad input: each case throws before solving, with a message naming the value.

namespace {
SimplexMesh<3> unit_tets() { return test::kuhn_box<3>({{2, 2, 2}}, {{0, 0, 0}}, {{1, 1, 1}}); }
template <class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}
}  // namespace

TEST(BadInput, PoissonRatio) {
  const auto mesh = unit_tets();
  const std::vector<double> E(mesh.n_cells(), 1.0);
  for (double nu : {0.5, 0.7, -1.0, std::nan("")}) {
    EXPECT_THROW(ElasticModel<3>(mesh, E, nu), std::invalid_argument);
    EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, E, nu); }), HasSubstr("outside (-1, 0.5)"));
  }
  EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, E, 0.5); }), HasSubstr("Poisson ratio 0.5"));
}

TEST(BadInput, Modulus) {
  const auto mesh = unit_tets();
  std::vector<double> E(mesh.n_cells(), 1.0);
  E[7] = -2.0;
  EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, E, 0.3); }), HasSubstr("cell 7 is -2"));
  E[7] = std::nan("");
  EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, E, 0.3); }), HasSubstr("cell 7 is nan"));
  E[7] = 0.0;
  EXPECT_THROW(ElasticModel<3>(mesh, E, 0.3), std::invalid_argument);
  E.pop_back();
  EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, E, 0.3); }),
              HasSubstr("47 Young's moduli given for 48 cells"));
  EXPECT_THAT(message_of([&] { ElasticModel<3>(mesh, std::vector<double>(48, 1.0), 0.3, 3); }),
              HasSubstr("degree 3"));
}

TEST(BadInput, InvertedAndDegenerateCells) {
  auto mesh = unit_tets();
  const std::vector<double> E(mesh.n_cells(), 1.0);
  // cells listed with the other orientation are fine (deal.II reorders them)...
  auto flipped = mesh;
  for (std::size_t c = 0; c < flipped.n_cells(); c += 2) std::swap(flipped.cells[c][0], flipped.cells[c][1]);
  EXPECT_NO_THROW(ElasticModel<3>(flipped, E, 0.3));
  // ...but a node pushed through its neighbours tangles the mesh
  auto tangled = mesh;
  for (auto& p : tangled.points)
    if ((p - Eigen::Vector3d(0.5, 0.5, 0.5)).norm() < 1e-12) p = Eigen::Vector3d(0.5, 0.5, 1.3);
  const std::string msg = message_of([&] { ElasticModel<3>(tangled, E, 0.3); });
  EXPECT_THAT(msg, HasSubstr("is inverted"));
  auto flat = mesh;
  flat.points[flat.cells[5][3]] =
      flat.points[flat.cells[5][0]] + 0.5 * (flat.points[flat.cells[5][1]] - flat.points[flat.cells[5][0]]);
  EXPECT_THROW(ElasticModel<3>(flat, E, 0.3), std::invalid_argument);
  SimplexMesh<2> tri;
  tri.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(2, 0)};
  tri.cells = {{{0, 1, 2}}};
  EXPECT_THAT(message_of([&] { ElasticModel<2>(tri, {1.0}, 0.3); }), HasSubstr("cell 0 is degenerate"));
  tri.cells = {{{0, 1, 5}}};
  EXPECT_THAT(message_of([&] { ElasticModel<2>(tri, {1.0}, 0.3); }), HasSubstr("refers to vertex 5"));
  // three triangles on edge 0-1 (the first two on opposite sides): the third is reported
  SimplexMesh<2> fan;
  fan.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0.5, 1),
                Eigen::Vector2d(0.5, -1), Eigen::Vector2d(0.5, 2)};
  fan.cells = {{{0, 1, 2}}, {{1, 0, 3}}, {{0, 1, 4}}};
  EXPECT_THAT(message_of([&] {
                ElasticModel<2>(fan, {1.0, 1.0, 1.0}, 0.3);
              }),
              HasSubstr("cell 2 shares a face with two other cells"));
  // two triangles on the same side of one edge overlap: reported at the second, naming the first
  fan.cells = {{{0, 1, 2}}, {{1, 0, 4}}};
  EXPECT_THAT(message_of([&] {
                ElasticModel<2>(fan, {1.0, 1.0}, 0.3);
              }),
              HasSubstr("cell 1 is inverted: it overlaps cell 0"));
}

TEST(BadInput, SingularSystems) {
  const auto mesh = unit_tets();
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3);
  EXPECT_THAT(message_of([&] { model.solve(); }), HasSubstr("no Dirichlet condition constrains any node"));
  DirichletBC<3> nowhere;
  nowhere.region = sphere_region<3>(Vec<3>(5, 5, 5), 0.1);
  model.add_dirichlet(nowhere);
  EXPECT_THAT(message_of([&] { model.solve(); }), HasSubstr("'sphere' select no node"));
  DirichletBC<3> only_z;  // one component on one face: sliding and in-plane rotation stay free
  only_z.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, false, 1e-9);
  only_z.components = {{false, false, true}};
  model.add_dirichlet(only_z);
  EXPECT_THAT(message_of([&] { model.solve(); }), HasSubstr("rigid-body motion"));
  EXPECT_THROW(model.solve_monolithic({}), std::runtime_error);
  DirichletBC<3> line;  // plus one fixed edge: now determinate
  line.region = {"edge", [](const Vec<3>& x) { return x[1] < 1e-9 && x[2] < 1e-9; }};
  model.add_dirichlet(line);
  EXPECT_NO_THROW(model.solve());
}

TEST(BadInput, PointConstraintsAndOptions) {
  auto model = needle_block<3>(1);
  EXPECT_THAT(message_of([&] { model.solve({PointConstraint<3>{Vec<3>(0.5, 0.5, 1.5)}}); }),
              HasSubstr("point constraint 0 at (0.5, 0.5, 1.5) lies outside the mesh"));
  PointConstraint<3> p{Vec<3>(0.5, 0.5, 0.5)}, q{Vec<3>(0.5, 0.5, 0.5), Vec<3>(0, 0, 0.01)};
  EXPECT_THAT(message_of([&] {
                model.solve({p, q});
              }),
              HasSubstr("point constraint 1 (component 2) conflicts with earlier point constraints"));
  EXPECT_THROW(model.solve_monolithic({p, q}), std::runtime_error);
  PointConstraint<3> on_fixed{Vec<3>(0.5, 0.5, 0.0), Vec<3>(0, 0, 0.1)};
  EXPECT_THAT(message_of([&] { model.solve({on_fixed}); }), HasSubstr("lies on Dirichlet-constrained nodes"));
  SolverOptions bad;
  bad.tolerance = -1;
  EXPECT_THAT(message_of([&] { model.solve({}, bad); }), HasSubstr("tolerance"));
  EXPECT_THAT(message_of([&] {
                ElasticModel<3>::voxel_grid({{2, 0, 2}}, Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), {}, 0.3);
              }),
              HasSubstr("0 cells along axis 1"));
  EXPECT_THAT(message_of([&] {
                ElasticModel<3>::voxel_grid({{2, 2, 2}}, Vec<3>(0, 0, 0), Vec<3>(1, 1, 1),
                                            std::vector<double>(7, 1.0), 0.3);
              }),
              HasSubstr("7 Young's moduli given for 8 cells"));
  ElasticModel<3> fresh(unit_tets(), std::vector<double>(48, 1.0), 0.3);
  EXPECT_THAT(message_of([&] { fresh.sample({Vec<3>(0.5, 0.5, 0.5)}); }), HasSubstr("no solution yet"));
}

// ---- volume supports (elastic foundation) ---------------------------------------------------------
namespace {

// Lattice of pitch h over the box [0, L]×[0, W]×[0, W] (cell centres), weight h³ each.
VolumeSupport<3> foundation(double L, double W, double h, double k) {
  VolumeSupport<3> s;
  s.name = "foundation";
  s.stiffness = k;
  const int nx = static_cast<int>(std::lround(L / h)), ny = static_cast<int>(std::lround(W / h));
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int l = 0; l < ny; ++l) {
        s.points.emplace_back((i + 0.5) * h, (j + 0.5) * h, (l + 0.5) * h);
        s.weights.push_back(h * h * h);
      }
  return s;
}

// Bar on an elastic foundation: ν = 0, the x = 0 face pushed by u0 along x (other components free),
// every other face traction-free, foundation k over the whole bar. u = (g(x), 0, 0) with E g'' = k g,
// g(0) = u0, g'(L) = 0: g(x) = u0 cosh((L − x)/ℓ) / cosh(L/ℓ), ℓ = sqrt(E/k). Without the support the
// bar would just translate (g = u0).
double foundation_bar_error(ElasticModel<3>& model, double L, double W, double u0, double ell) {
  DirichletBC<3> push;
  push.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(L, W, W), 0, false, 1e-9);
  push.components = {{true, false, false}};
  push.value = Vec<3>(u0, 0, 0);
  model.add_dirichlet(push);
  model.solve();
  std::vector<Vec<3>> probes;
  for (double x : {0.5, 1.0, 2.0, 3.0}) probes.emplace_back(x, 0.5 * W, 0.5 * W);
  const auto u = model.sample(probes);
  double err = 0.0;
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const double g = u0 * std::cosh((L - probes[i][0]) / ell) / std::cosh(L / ell);
    err = std::max(err, (u[i] - Vec<3>(g, 0, 0)).norm() / u0);
  }
  return err;
}

}  // namespace

TEST(VolumeSupport, BarOnAnElasticFoundationMatchesTheCoshSolution) {
  const double L = 4.0, W = 0.5, E = 2.0, k = 2.0, u0 = 0.1;  // ℓ = 1
  double previous = 1.0;
  for (int cells : {8, 16, 32}) {
    const auto mesh = test::kuhn_box<3>({{cells, 2, 2}}, {{0, 0, 0}}, {{L, W, W}});
    ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), E), 0.0, 2);
    model.add_volume_support(foundation(L, W, 0.05, k));
    const double err = foundation_bar_error(model, L, W, u0, 1.0);
    EXPECT_EQ(model.volume_support_points_outside(), 0u);
    EXPECT_LT(err, previous) << cells << " cells";  // converges under refinement
    previous = err;
  }
  EXPECT_LT(previous, 2e-3);  // 32 P2 cells along the bar; the lattice quadrature (h = 0.05) is the limit
  // The voxel (Q1) reference with the same points: the same solution.
  auto voxel = ElasticModel<3>::voxel_grid({{40, 5, 5}}, Vec<3>(0, 0, 0), Vec<3>(L, W, W),
                                           std::vector<double>(1000, E), 0.0);
  voxel.add_volume_support(foundation(L, W, 0.05, k));
  EXPECT_LT(foundation_bar_error(voxel, L, W, u0, 1.0), 1e-2);
  // Without the support the x-only push leaves the bar free: a rigid motion.
  const auto mesh = test::kuhn_box<3>({{4, 1, 1}}, {{0, 0, 0}}, {{L, W, W}});
  ElasticModel<3> free_bar(mesh, std::vector<double>(mesh.n_cells(), E), 0.0, 1);
  EXPECT_THAT(message_of([&] { foundation_bar_error(free_bar, L, W, u0, 1.0); }),
              HasSubstr("rigid-body motion"));
}

TEST(VolumeSupport, HoldsTheBodyWhereNoNodeIsAndRejectsBadInput) {
  // One coarse cell layer; the support is a small ball around an interior point that is no node.
  const auto mesh = test::kuhn_box<3>({{2, 2, 2}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3, 1);
  VolumeSupport<3> ball;
  ball.name = "ball";
  ball.stiffness = 1e6;
  for (double x : {0.2, 0.25, 0.3})
    for (double y : {0.2, 0.25, 0.3})
      for (double z : {0.2, 0.25, 0.3}) ball.points.emplace_back(x, y, z), ball.weights.push_back(1e-3);
  ball.points.emplace_back(5, 5, 5);  // outside the mesh: ignored and counted
  ball.weights.push_back(1e-3);
  model.add_volume_support(ball);
  model.set_body_force(Vec<3>(0, 0, -1));
  const auto s = model.solve();  // the support alone removes the rigid motions
  EXPECT_EQ(model.volume_support_points_outside(), 1u);
  const auto u = model.sample({Vec<3>(0.25, 0.25, 0.25), Vec<3>(0.9, 0.9, 0.9)});
  EXPECT_LT(u[0].norm(), 1e-3 * u[1].norm());  // held where the points are
  EXPECT_GT(u[1].norm(), 0.1);                 // the far corner hangs from it
  // Equilibrium: the support carries the whole body force (weight 1 × volume 1): Σ k w_p u(x_p) = (0, 0, −1).
  std::vector<Vec<3>> inside(ball.points.begin(), ball.points.end() - 1);
  Vec<3> reaction = Vec<3>::Zero();
  for (const auto& up : model.sample(inside)) reaction += ball.stiffness * 1e-3 * up;
  EXPECT_NEAR(reaction[2], -1.0, 1e-8);
  EXPECT_NEAR(reaction.head<2>().norm(), 0.0, 1e-8);
  VolumeSupport<3> bad = ball;
  bad.stiffness = 0.0;
  EXPECT_THAT(message_of([&] { model.add_volume_support(bad); }),
              HasSubstr("stiffness must be finite and > 0"));
  bad = ball;
  bad.weights.pop_back();
  EXPECT_THAT(message_of([&] { model.add_volume_support(bad); }), HasSubstr("weights"));
  EXPECT_THROW(solve_distributed(model, MPI_COMM_SELF), std::invalid_argument);
}

// A base moved by T carries a body the foundation alone holds rigidly: the elastic stiffness does nothing
// to a translation and, by the partition of unity, Σ_j k w N_i N_j T = k w N_i T, so u = T exactly. And
// moving the base after solves with point constraints changes the load alone: the next solve (the same
// factor, the cached columns K⁻¹cᵀ with their c·u0 renewed) equals a model built with that base.
TEST(VolumeSupport, MovedBaseCarriesAFreeBodyRigidlyAndChangesTheLoadAlone) {
  const auto mesh = test::kuhn_box<3>({{3, 2, 2}}, {{0, 0, 0}}, {{3, 1, 1}});
  const VolumeSupport<3> sup = foundation(3.0, 1.0, 0.25, 5.0);
  ElasticModel<3> free_body(mesh, std::vector<double>(mesh.n_cells(), 2.0), 0.3, 2);
  free_body.add_volume_support(sup);
  for (const auto& v : free_body.solve().vertex_displacement) EXPECT_LT(v.norm(), 1e-14);  // at rest
  const Vec<3> T(0.1, -0.2, 0.05);
  free_body.set_volume_support_base(0, std::vector<Vec<3>>(sup.points.size(), T));
  const Solution<3> carried = free_body.solve();
  for (const auto& v : carried.vertex_displacement) EXPECT_LT((v - T).norm(), 1e-10);
  EXPECT_LT(std::abs(carried.strain_energy), 1e-12);
  // A sheared base (b = (0.1 z, 0.05 x, 0)) under a fixed face x = 0 and a point held inside.
  std::vector<Vec<3>> base;
  for (const auto& x : sup.points) base.emplace_back(0.1 * x[2], 0.05 * x[0], 0.0);
  DirichletBC<3> face;
  face.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(3, 1, 1), 0, false, 1e-9);
  const std::vector<PointConstraint<3>> held = {
      PointConstraint<3>(Vec<3>(2.1, 0.4, 0.6), Vec<3>(0.02, 0, 0))};
  ElasticModel<3> moved(mesh, std::vector<double>(mesh.n_cells(), 2.0), 0.3, 2);
  moved.add_dirichlet(face);
  moved.add_volume_support(sup);
  moved.solve(held);  // factorised, the held point's columns cached at rest
  moved.set_volume_support_base(0, base);
  const Solution<3> after = moved.solve(held);
  VolumeSupport<3> built = sup;
  built.base = base;
  ElasticModel<3> fresh(mesh, std::vector<double>(mesh.n_cells(), 2.0), 0.3, 2);
  fresh.add_dirichlet(face);
  fresh.add_volume_support(built);
  const Solution<3> reference = fresh.solve(held);
  double largest = 0.0, difference = 0.0;
  for (std::size_t v = 0; v < after.vertex_displacement.size(); ++v) {
    largest = std::max(largest, reference.vertex_displacement[v].norm());
    difference =
        std::max(difference, (after.vertex_displacement[v] - reference.vertex_displacement[v]).norm());
  }
  EXPECT_GT(largest, 0.05);
  EXPECT_LT(difference, 1e-12);
  EXPECT_LT((after.point_force[0] - reference.point_force[0]).norm(), 1e-10);
  EXPECT_LT((after.dirichlet_reaction[0] - reference.dirichlet_reaction[0]).norm(), 1e-10);
  EXPECT_THAT(message_of([&] { moved.set_volume_support_base(1, base); }), HasSubstr("no volume support 1"));
  base.pop_back();
  EXPECT_THAT(message_of([&] { moved.set_volume_support_base(0, base); }),
              HasSubstr("base displacements for"));
}

// DirichletBC::axes. Independent truth: the same body rotated by R, with its supports along the
// rotated model's own axes (the plain per-DoF path). Body A lives in the unit box; body B = R·A. On A,
// the supports act along B's axes seen from A (axes = Rᵀ): a sliding support on A's face x = 0 that
// holds B's x component only, and on A's face x = 1 B's y (and z) components displaced. A traction on
// A's face y = 1, a body force and embedded points near the sliding face (their rows reach the
// sliding DoFs). Then u_A = Rᵀ u_B at every vertex, the reactions and point forces rotate alike, and
// the strain energies agree, for the fast path and the monolithic solve.
namespace {

template <int dim>
Eigen::Matrix<double, dim, dim> test_rotation() {
  if constexpr (dim == 2) {
    return Eigen::Rotation2Dd(0.6).toRotationMatrix();
  } else {
    return Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  }
}

template <int dim>
void rotated_axes_match_the_rotated_body(unsigned degree) {
  using M = Eigen::Matrix<double, dim, dim>;
  const M R = test_rotation<dim>();
  const SimplexMesh<dim> a_mesh = perturbed_unit_box<dim>(dim == 2 ? 5 : 3, 11);
  SimplexMesh<dim> b_mesh = a_mesh;
  for (auto& p : b_mesh.points) p = R * p;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> P(1.0, 4.0);
  std::vector<double> E(a_mesh.n_cells());
  for (auto& e : E) e = P(rng);
  ElasticModel<dim> a(a_mesh, E, 0.3, degree), b(b_mesh, E, 0.3, degree);
  // Regions by A's coordinates; B sees them through Rᵀ.
  auto face = [](int axis, double at) {
    return [axis, at](const Vec<dim>& x) { return std::abs(x[axis] - at) < 1e-9; };
  };
  auto on_a = [](const std::function<bool(const Vec<dim>&)>& f, const char* name) {
    return Region<dim>{name, f};
  };
  auto on_b = [R](const std::function<bool(const Vec<dim>&)>& f, const char* name) {
    return Region<dim>{name, [R, f](const Vec<dim>& x) { return f(R.transpose() * x); }};
  };
  Vec<dim> pushed = Vec<dim>::Zero();
  pushed[1] = 0.05;
  if (dim == 3) pushed[dim - 1] = -0.02;
  for (int body = 0; body < 2; ++body) {
    ElasticModel<dim>& m = body == 0 ? a : b;
    auto region = [&](const std::function<bool(const Vec<dim>&)>& f, const char* name) {
      return body == 0 ? on_a(f, name) : on_b(f, name);
    };
    DirichletBC<dim> slide;
    slide.region = region(face(0, 0.0), "x0");
    slide.components = DirichletBC<dim>::filled(false);
    slide.components[0] = true;
    DirichletBC<dim> push;
    push.region = region(face(0, 1.0), "x1");
    push.components = DirichletBC<dim>::filled(true);
    push.components[0] = false;
    push.value = pushed;
    if (body == 0) slide.axes = push.axes = R.transpose();
    m.add_dirichlet(slide);
    m.add_dirichlet(push);
    SurfaceLoad<dim> load;
    load.region = region(face(1, 1.0), "y1");
    const Vec<dim> t = Vec<dim>::Constant(0.3);
    load.traction = body == 0 ? Vec<dim>(R.transpose() * t) : t;
    m.add_surface_load(load);
    const Vec<dim> f = Vec<dim>::Constant(-0.2);
    m.set_body_force(body == 0 ? Vec<dim>(R.transpose() * f) : f);
  }
  std::vector<PointConstraint<dim>> pa, pb;
  for (int k = 0; k < 3; ++k) {
    PointConstraint<dim> p;
    const double spread[3][3] = {
        {0.08, 0.3, 0.6}, {0.12, 0.7, 0.4}, {0.1, 0.5, 0.15}};  // in cells on the sliding face
    for (int d = 0; d < dim; ++d) p.position[d] = spread[k][d];
    p.displacement = Vec<dim>::Constant(0.01 * (k + 1));
    pa.push_back(p);
    p.position = R * p.position;
    p.displacement = R * p.displacement;
    pb.push_back(p);
  }
  {
    // PointConstraint::axes: a point held in B's x only (and y in 3D), stated on A along B's axes.
    PointConstraint<dim> p;
    p.position = Vec<dim>::Constant(0.7);
    p.displacement = Vec<dim>::Constant(-0.01);
    p.components = DirichletBC<dim>::filled(false);
    for (int c = 0; c < std::min(dim - 1, 2); ++c) p.components[c] = true;
    PointConstraint<dim> q = p;
    q.position = R * p.position;
    p.axes = R.transpose();
    pa.push_back(p);
    pb.push_back(q);
  }
  for (int monolithic = 0; monolithic < 2; ++monolithic) {
    const auto sa = monolithic ? a.solve_monolithic(pa) : a.solve(pa);
    const auto sb = monolithic ? b.solve_monolithic(pb) : b.solve(pb);
    double umax = 0.0, rmax = 0.0;
    for (const auto& u : sb.vertex_displacement) umax = std::max(umax, u.norm());
    for (const auto& r : sb.dirichlet_reaction) rmax = std::max(rmax, r.norm());
    ASSERT_GT(umax, 0.01);
    ASSERT_GT(rmax, 0.01);
    for (std::size_t i = 0; i < a_mesh.n_points(); ++i)
      ASSERT_LT((sa.vertex_displacement[i] - R.transpose() * sb.vertex_displacement[i]).norm(), 1e-9 * umax)
          << "vertex " << i;
    // The sliding face moves along it only: B's x component is 0 there (A's x = 0 face).
    for (std::size_t i = 0; i < a_mesh.n_points(); ++i)
      if (std::abs(a_mesh.points[i][0]) < 1e-9) {
        ASSERT_NEAR((R * sa.vertex_displacement[i])[0], 0.0, 1e-12 * umax);
      }
    EXPECT_NEAR(sa.strain_energy, sb.strain_energy, 1e-9 * sb.strain_energy);
    for (std::size_t k = 0; k < 2; ++k)
      EXPECT_LT((sa.dirichlet_reaction[k] - R.transpose() * sb.dirichlet_reaction[k]).norm(), 1e-8 * rmax)
          << "condition " << k;
    for (std::size_t k = 0; k < pa.size(); ++k)
      EXPECT_LT((sa.point_force[k] - R.transpose() * sb.point_force[k]).norm(), 1e-8 * rmax) << "point " << k;
    // A sliding support's reaction is normal to its plane: along B's x only.
    const Vec<dim> r0 = R * sa.dirichlet_reaction[0];
    EXPECT_LT(r0.template tail<dim - 1>().norm(), 1e-8 * r0.norm());
  }
}

}  // namespace

TEST(RotatedAxes, SlidingSupportMatchesTheRotatedBodyP1_3D) { rotated_axes_match_the_rotated_body<3>(1); }
TEST(RotatedAxes, SlidingSupportMatchesTheRotatedBodyP2_3D) { rotated_axes_match_the_rotated_body<3>(2); }
TEST(RotatedAxes, SlidingSupportMatchesTheRotatedBodyP1_2D) { rotated_axes_match_the_rotated_body<2>(1); }

TEST(RotatedAxes, RigidModesAndBadAxesAreReported) {
  const auto mesh = perturbed_unit_box<3>(2, 3);
  const Eigen::Matrix3d R = test_rotation<3>();
  // A sliding support alone (one plane, one direction) leaves in-plane motions free: singular.
  ElasticModel<3> m(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3, 1);
  DirichletBC<3> slide;
  slide.region = {"x0", [](const Vec<3>& x) { return std::abs(x[0]) < 1e-9; }};
  slide.components = {{true, false, false}};
  slide.axes = R.transpose();
  m.add_dirichlet(slide);
  EXPECT_THROW(m.solve(), SingularConstraints);
  // All three directions on that face hold it like a clamp: solvable, and the face does not move.
  ElasticModel<3> c(mesh, std::vector<double>(mesh.n_cells(), 1.0), 0.3, 1);
  DirichletBC<3> clamp = slide;
  clamp.components = {{true, true, true}};
  c.add_dirichlet(clamp);
  c.set_body_force(Vec<3>(0, 0, -1));
  const auto s = c.solve();
  for (std::size_t i = 0; i < mesh.n_points(); ++i)
    if (std::abs(mesh.points[i][0]) < 1e-9) {
      EXPECT_LT(s.vertex_displacement[i].norm(), 1e-12);
    }
  EXPECT_NEAR(s.dirichlet_reaction[0][2], 1.0, 1e-9);  // it carries the body force
  DirichletBC<3> skew = slide;
  skew.axes(0, 0) = 2.0;
  EXPECT_THAT([&] { m.add_dirichlet(skew); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("not orthonormal")));
  PointConstraint<3> p;
  p.position = Vec<3>::Constant(0.5);
  p.axes = skew.axes;
  EXPECT_THAT([&] { c.solve({p}); }, ::testing::ThrowsMessage<std::invalid_argument>(
                                         HasSubstr("point constraint 0 has axes that are not orthonormal")));
}

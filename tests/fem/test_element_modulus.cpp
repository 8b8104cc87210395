// Eq. 15 (paper §VI-C): for a P1 field the element strain energy with E_j = volume average of E(x)
// equals ½ ε:C(ν):ε ∫τ E dx. (a) voxel-wise constant E, ∫τE by exact clipping of the tet against
// every voxel box; (b) with the voxel-centre mean the error falls as the image is refined;
// (c) ½uᵀKu assembled by deal.II equals the sum of analytic element energies for random P1 fields.
// Plus the element_modulus / block_mean helpers.
#include "box_mesh.hpp"

#include <vim/fem/elasticity.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>

using namespace vim;
using namespace vim::fem;
using ::testing::HasSubstr;

namespace {

using V3 = Eigen::Vector3d;
using Polygon = std::vector<V3>;

// Convex polyhedron as its face polygons, clipped by the half-space n·x <= d (Sutherland–Hodgman on
// every face; the cut points form the new cap face).
std::vector<Polygon> clip(const std::vector<Polygon>& faces, const V3& n, double d) {
  std::vector<Polygon> out;
  std::vector<V3> cut;
  for (const auto& f : faces) {
    Polygon g;
    for (std::size_t i = 0; i < f.size(); ++i) {
      const V3& a = f[i];
      const V3& b = f[(i + 1) % f.size()];
      const double da = n.dot(a) - d, db = n.dot(b) - d;
      if (da <= 0) g.push_back(a);
      if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
        const V3 x = a + (da / (da - db)) * (b - a);
        g.push_back(x);
        cut.push_back(x);
      }
      if (da == 0) cut.push_back(a);
    }
    if (g.size() >= 3) out.push_back(g);
  }
  if (cut.size() >= 3) {
    V3 c = V3::Zero();
    for (const auto& p : cut) c += p;
    c /= static_cast<double>(cut.size());
    const V3 e1 = (std::abs(n[0]) < 0.9 ? V3::UnitX() : V3::UnitY()).cross(n).normalized();
    const V3 e2 = n.cross(e1).normalized();
    std::sort(cut.begin(), cut.end(), [&](const V3& p, const V3& q) {
      return std::atan2((p - c).dot(e2), (p - c).dot(e1)) < std::atan2((q - c).dot(e2), (q - c).dot(e1));
    });
    out.push_back(cut);
  }
  return out;
}

double volume(const std::vector<Polygon>& faces) {
  if (faces.empty()) return 0.0;
  V3 c = V3::Zero();
  int n = 0;
  for (const auto& f : faces)
    for (const auto& p : f) c += p, ++n;
  c /= n;
  double v = 0;
  for (const auto& f : faces)
    for (std::size_t i = 1; i + 1 < f.size(); ++i) {
      Eigen::Matrix3d m;
      m << f[0] - c, f[i] - c, f[i + 1] - c;
      v += std::abs(m.determinant()) / 6.0;
    }
  return v;
}

std::vector<Polygon> tet_faces(const std::array<V3, 4>& x) {
  return {{x[1], x[2], x[3]}, {x[0], x[2], x[3]}, {x[0], x[1], x[3]}, {x[0], x[1], x[2]}};
}

double tet_box_volume(const std::array<V3, 4>& x, const V3& lo, const V3& hi) {
  auto f = tet_faces(x);
  for (int d = 0; d < 3 && !f.empty(); ++d) {
    f = clip(f, V3::Unit(d), hi[d]);
    f = clip(f, -V3::Unit(d), -lo[d]);
  }
  return volume(f);
}

// ½ ε:C(ν):ε per unit Young's modulus.
template <int dim>
double energy_density(const Eigen::Matrix<double, dim, dim>& grad, double nu) {
  const Eigen::Matrix<double, dim, dim> eps = 0.5 * (grad + grad.transpose());
  const auto [lambda, mu] = lame_parameters(1.0, nu);
  return 0.5 * (lambda * eps.trace() * eps.trace() + 2 * mu * (eps.array() * eps.array()).sum());
}

SimplexMesh<3> one_tet(const std::array<V3, 4>& x) {
  SimplexMesh<3> m;
  m.points.assign(x.begin(), x.end());
  m.cells = {{{0, 1, 2, 3}}};
  return m;
}

const std::array<V3, 4> kTet = {
    {V3(0.13, 0.21, 0.08), V3(0.91, 0.33, 0.17), V3(0.27, 0.87, 0.24), V3(0.41, 0.38, 0.93)}};

}  // namespace

TEST(Eq15, ExactVolumeAverageGivesExactElementEnergy) {
  const int N = 9;  // voxels per axis over [0, 1]^3; voxel-wise constant, strongly varying E
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(1.0, 50.0), D(-1.0, 1.0);
  std::vector<double> image(N * N * N);
  for (auto& v : image) v = U(rng);
  double integral = 0, covered = 0;
  for (int k = 0; k < N; ++k)
    for (int j = 0; j < N; ++j)
      for (int i = 0; i < N; ++i) {
        const double vol = tet_box_volume(kTet, V3(i, j, k) / N, V3(i + 1, j + 1, k + 1) / N);
        integral += vol * image[i + N * (j + N * k)];
        covered += vol;
      }
  const double tet_volume = signed_volume<3>(kTet);
  ASSERT_NEAR(covered, std::abs(tet_volume), 1e-14);  // the clipping partitions the tet exactly
  Eigen::Matrix3d A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = D(rng);
  std::vector<Vec<3>> U4;
  for (const auto& x : kTet) U4.push_back(A * x + V3(0.1, -0.2, 0.3));
  for (double nu : {0.0, 0.3, 0.49}) {
    for (unsigned degree : {1u, 2u}) {
      ElasticModel<3> model(one_tet(kTet), {integral / std::abs(tet_volume)}, nu, degree);
      const double fe = model.strain_energy_of(U4);
      const double exact = energy_density<3>(A, nu) * integral;
      EXPECT_NEAR(fe, exact, 1e-12 * exact) << "nu " << nu << " degree " << degree;
    }
  }
}

TEST(Eq15, VoxelCentreMeanConvergesUnderRefinement) {
  // smooth E(x) = 2 + x + 3y² + 2xz; ∫τE exact with the degree-2 rule (vertices −1/20, edge midpoints 1/5)
  auto Ef = [](const V3& p) { return 2 + p[0] + 3 * p[1] * p[1] + 2 * p[0] * p[2]; };
  const double vol = std::abs(signed_volume<3>(kTet));
  double integral = 0;
  for (int a = 0; a < 4; ++a) {
    integral -= Ef(kTet[a]) / 20.0;
    for (int b = a + 1; b < 4; ++b) integral += Ef(0.5 * (kTet[a] + kTet[b])) / 5.0;
  }
  integral *= vol;
  Eigen::Matrix3d A;
  A << 0.3, -0.1, 0.2, 0.05, -0.4, 0.1, 0.2, 0.15, 0.25;
  std::vector<Vec<3>> U4;
  for (const auto& x : kTet) U4.push_back(A * x);
  const double exact = energy_density<3>(A, 0.45) * integral;
  Eigen::Matrix3d T;
  for (int d = 0; d < 3; ++d) T.col(d) = kTet[d + 1] - kTet[0];
  const Eigen::Matrix3d Ti = T.inverse();
  std::vector<double> errors;
  for (int N : {8, 32, 128}) {
    double s = 0;
    long n = 0;
    for (int k = 0; k < N; ++k)
      for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
          const V3 c = (V3(i, j, k) + V3::Constant(0.5)) / N;
          const V3 l = Ti * (c - kTet[0]);
          if (l.minCoeff() >= 0 && l.sum() <= 1) s += Ef(c), ++n;
        }
    ASSERT_GT(n, 0);
    const auto E = element_modulus({s / n});
    ElasticModel<3> model(one_tet(kTet), E, 0.45, 1);
    errors.push_back(std::abs(model.strain_energy_of(U4) - exact) / exact);
  }
  std::printf("Eq.15 voxel-centre mean, relative energy error at N = 8, 32, 128: %.3e %.3e %.3e\n", errors[0],
              errors[1], errors[2]);
  EXPECT_LT(errors[1], errors[0]);
  EXPECT_LT(errors[2], errors[1]);
  EXPECT_LT(errors[2], 0.01);
}

template <int dim>
void random_fields_energy(unsigned degree) {
  std::array<int, dim> cells;
  std::array<double, dim> lo, hi;
  cells.fill(3), lo.fill(0.0), hi.fill(2.0);
  auto mesh = test::kuhn_box<dim>(cells, lo, hi);
  std::mt19937 rng(5 + dim);
  std::uniform_real_distribution<double> U(-1, 1), P(0.5, 20);
  for (auto& p : mesh.points) {
    bool interior = true;
    for (int d = 0; d < dim; ++d) interior = interior && p[d] > 1e-9 && p[d] < 2 - 1e-9;
    if (interior)
      for (int d = 0; d < dim; ++d) p[d] += 0.1 * U(rng);
  }
  std::vector<double> E(mesh.n_cells());
  for (auto& e : E) e = P(rng);
  const double nu = 0.37;
  ElasticModel<dim> model(mesh, E, nu, degree);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<Vec<dim>> u(mesh.n_points());
    for (auto& v : u)
      for (int d = 0; d < dim; ++d) v[d] = U(rng);
    double analytic = 0;
    for (std::size_t t = 0; t < mesh.n_cells(); ++t) {
      const auto x = cell_points(mesh, t);
      Eigen::Matrix<double, dim, dim> X, Du;
      for (int d = 0; d < dim; ++d) {
        X.col(d) = x[d + 1] - x[0];
        Du.col(d) = u[mesh.cells[t][d + 1]] - u[mesh.cells[t][0]];
      }
      const Eigen::Matrix<double, dim, dim> grad = Du * X.inverse();
      analytic += energy_density<dim>(grad, nu) * E[t] * std::abs(signed_volume(mesh, t));
    }
    EXPECT_NEAR(model.strain_energy_of(u), analytic, 1e-12 * analytic) << "trial " << trial;
  }
}

TEST(Eq15, AssembledEnergyEqualsAnalyticElementEnergies) {
  random_fields_energy<3>(1);
  random_fields_energy<2>(1);
  random_fields_energy<3>(2);  // P2 represents the P1 field exactly
}

// And the energy reported by a solve is ½uᵀKu of its own solution: check against strain_energy_of.
TEST(Eq15, SolutionEnergyIsHalfUKU) {
  const auto mesh = test::kuhn_box<3>({{3, 3, 3}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), 4.0), 0.3, 1);
  DirichletBC<3> bc;
  bc.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, false, 1e-9);
  model.add_dirichlet(bc);
  SurfaceLoad<3> load;
  load.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, true, 1e-9);
  load.pressure = 0.3;
  load.traction = Vec<3>(0.1, 0, 0);
  model.add_surface_load(load);
  const auto s = model.solve();
  EXPECT_NEAR(s.strain_energy, model.strain_energy_of(s.vertex_displacement), 1e-12 * s.strain_energy);
  // Clapeyron: 2·energy = work of the loads = ∫ (t − p n)·u over the top face, u linear per triangle
  const V3 t(0.1, 0, -0.3);
  double work = 0;
  for (const auto& c : mesh.cells)
    for (int k = 0; k < 4; ++k) {
      std::vector<int> f;
      for (int i = 0; i < 4; ++i)
        if (i != k && std::abs(mesh.points[c[i]][2] - 1) < 1e-12) f.push_back(c[i]);
      if (f.size() != 3) continue;
      const double area = 0.5 * (mesh.points[f[1]] - mesh.points[f[0]]).cross(mesh.points[f[2]] - mesh.points[f[0]]).norm();
      for (int v : f) work += area / 3.0 * t.dot(s.vertex_displacement[v]);
    }
  EXPECT_GT(s.strain_energy, 0);
  EXPECT_NEAR(2 * s.strain_energy, work, 1e-10 * work);
}

TEST(ElementModulus, ScaleClampAndErrors) {
  EXPECT_EQ(element_modulus({1.0, 2.0}, 3.0), (std::vector<double>{3.0, 6.0}));
  EXPECT_EQ(element_modulus({-1.0, 2.0, 50.0}, 1.0, std::make_pair(0.5, 10.0)), (std::vector<double>{0.5, 2.0, 10.0}));
  auto msg = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(no exception)");
  };
  EXPECT_THAT(msg([] { element_modulus({1.0, 2.0, -4.0}); }), HasSubstr("element 2 gets a non-positive modulus -4"));
  EXPECT_THAT(msg([] { element_modulus({1.0, std::nan("")}, 1.0, std::make_pair(1.0, 2.0)); }),
              HasSubstr("element 1 has a non-finite mean value nan"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 0.0); }), HasSubstr("scale must be finite and > 0, got 0"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 1.0, std::make_pair(0.0, 2.0)); }), HasSubstr("clamp [0, 2] is invalid"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 1.0, std::make_pair(3.0, 2.0)); }), HasSubstr("clamp [3, 2] is invalid"));
}

TEST(ElementModulus, BlockMean) {
  std::vector<double> v(4 * 6);
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 4; ++i) v[i + 4 * j] = i + 10.0 * j;
  std::array<long, 2> cd;
  const auto c = block_mean<2>({{4, 6}}, v, 2, &cd);
  EXPECT_EQ(cd, (std::array<long, 2>{{2, 3}}));
  ASSERT_EQ(c.size(), 6u);
  for (int J = 0; J < 3; ++J)
    for (int I = 0; I < 2; ++I) EXPECT_DOUBLE_EQ(c[I + 2 * J], 2 * I + 0.5 + 10.0 * (2 * J + 0.5));
  EXPECT_THROW(block_mean<2>({{4, 5}}, std::vector<double>(20), 2), std::invalid_argument);
}

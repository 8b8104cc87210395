// Truths: ∫τE by exact clipping (clip_volume.hpp) or by an exact quadrature rule, and the analytic
// element energy ½ ε:C(ν):ε·E·|τ| (strain_energy_density.hpp). Eq. 15 (paper §VI-C): for a P1 field the
// element strain energy with E_j = volume average of E(x) equals ½ ε:C(ν):ε ∫τ E dx; the element mean
// the mesher computes (VoxelStatistics, voxel centres in τ) converges to that average as the image is
// refined, (a) for a block image, (b) for a smooth E; (c) ½uᵀKu assembled by deal.II equals the sum
// of analytic element energies for random P1 fields. Plus the element_modulus / block_mean helpers.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vim/fem/elasticity.hpp>
#include <vim/voxel_statistics.hpp>

#include "box_mesh.hpp"
#include "clip_volume.hpp"
#include "strain_energy_density.hpp"

using namespace vim;
using namespace vim::fem;
using ::testing::HasSubstr;

namespace {

using V3 = Eigen::Vector3d;

SimplexMesh<3> one_tet(const std::array<V3, 4>& x) {
  SimplexMesh<3> m;
  m.points.assign(x.begin(), x.end());
  m.cells = {{{0, 1, 2, 3}}};
  return m;
}

const std::array<V3, 4> kTet = {
    {V3(0.13, 0.21, 0.08), V3(0.91, 0.33, 0.17), V3(0.27, 0.87, 0.24), V3(0.41, 0.38, 0.93)}};

}  // namespace

// The element mean the mesher computes for a 3×3×3 block image of strongly varying moduli over
// [0, 1]³ sampled with N voxels per block: its energy tends to ½ε:C:ε∫τE (∫τE clipped against the 27
// blocks) as N grows, for P1 and P2 (the voxel-centre count is exact only in the limit).
TEST(Eq15, MesherMeanOfABlockImageConvergesToTheExactElementEnergy) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(1.0, 50.0), D(-1.0, 1.0);
  std::vector<double> block(27);
  for (auto& v : block) v = static_cast<float>(U(rng));  // representable in the float image
  double integral = 0;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        integral += block[i + 3 * (j + 3 * k)] *
                    test::box_overlap<3>(kTet, V3(i, j, k) / 3, V3(i + 1, j + 1, k + 1) / 3);
  Eigen::Matrix3d A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = D(rng);
  std::vector<Vec<3>> U4;
  for (const auto& x : kTet) U4.push_back(A * x + V3(0.1, -0.2, 0.3));
  const double nu = 0.3, exact = test::strain_energy_density<3>(A, nu) * integral;
  std::vector<double> errors;
  for (const long n : {2L, 8L, 32L}) {
    const double h = 1.0 / (3 * n);
    Image<3> img({{3 * n, 3 * n, 3 * n}}, {{h, h, h}}, {{0.5 * h, 0.5 * h, 0.5 * h}});
    for (std::size_t v = 0; v < img.voxel_count(); ++v) {
      const auto i = img.index_of(v);
      img.data[v] = static_cast<float>(block[i[0] / n + 3 * (i[1] / n + 3 * (i[2] / n))]);
    }
    const ElementValue mean = VoxelStatistics<3>(img).value(kTet);
    ASSERT_GT(mean.voxels, 0);
    for (unsigned degree : {1u, 2u}) {
      ElasticModel<3> model(one_tet(kTet), element_modulus({mean.mean}), nu, degree);
      const double error = std::abs(model.strain_energy_of(U4) - exact) / exact;
      if (degree == 1)
        errors.push_back(error);
      else
        EXPECT_NEAR(error, errors.back(), 1e-10) << "P2 represents the P1 field exactly";
    }
  }
  std::printf("Eq.15 block image, relative energy error at N = 2, 8, 32 voxels per block: %.3e %.3e %.3e\n",
              errors[0], errors[1], errors[2]);
  EXPECT_LT(errors[1], errors[0]);
  EXPECT_LT(errors[2], errors[1]);
  EXPECT_LT(errors[2], 0.01);
}

// As above for a smooth E: ∫τE by the exact degree-2 rule, the mesher's mean of the sampled image.
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
  const double exact = test::strain_energy_density<3>(A, 0.45) * integral;
  std::vector<double> errors;
  for (const long N : {8L, 32L, 128L}) {
    const double h = 1.0 / N;
    Image<3> img({{N, N, N}}, {{h, h, h}}, {{0.5 * h, 0.5 * h, 0.5 * h}});
    for (std::size_t v = 0; v < img.voxel_count(); ++v)
      img.data[v] = static_cast<float>(Ef(img.point_of(img.index_of(v))));
    const ElementValue mean = VoxelStatistics<3>(img).value(kTet);
    ASSERT_GT(mean.voxels, 0);
    ElasticModel<3> model(one_tet(kTet), element_modulus({mean.mean}), 0.45, 1);
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
      analytic += test::strain_energy_density<dim>(grad, nu) * E[t] * std::abs(signed_volume(mesh, t));
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
      const double area =
          0.5 * (mesh.points[f[1]] - mesh.points[f[0]]).cross(mesh.points[f[2]] - mesh.points[f[0]]).norm();
      for (int v : f) work += area / 3.0 * t.dot(s.vertex_displacement[v]);
    }
  EXPECT_GT(s.strain_energy, 0);
  EXPECT_NEAR(2 * s.strain_energy, work, 1e-10 * work);
}

TEST(ElementModulus, ScaleClampAndErrors) {
  EXPECT_EQ(element_modulus({1.0, 2.0}, 3.0), (std::vector<double>{3.0, 6.0}));
  EXPECT_EQ(element_modulus({-1.0, 2.0, 50.0}, 1.0, std::make_pair(0.5, 10.0)),
            (std::vector<double>{0.5, 2.0, 10.0}));
  auto msg = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(no exception)");
  };
  EXPECT_THAT(msg([] {
                element_modulus({1.0, 2.0, -4.0});
              }),
              HasSubstr("element 2 gets a non-positive modulus -4"));
  EXPECT_THAT(msg([] {
                element_modulus({1.0, std::nan("")}, 1.0, std::make_pair(1.0, 2.0));
              }),
              HasSubstr("element 1 has a non-finite mean value nan"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 0.0); }), HasSubstr("scale must be finite and > 0, got 0"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 1.0, std::make_pair(0.0, 2.0)); }),
              HasSubstr("clamp [0, 2] is invalid"));
  EXPECT_THAT(msg([] { element_modulus({1.0}, 1.0, std::make_pair(3.0, 2.0)); }),
              HasSubstr("clamp [3, 2] is invalid"));
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

// Tests of the VIM energies (paper Eq. 3, 6, 7 and §IV-C) against independent truths: per-element E_G
// summed over a mesh equals Eq. 3 in its 1-ring form minus the analytic ∫|x|² over the box;
// single-element E_G equals a high-order quadrature of (I|x|² − |x|²); E_D equals a brute-force
// pairwise variance; the normalised E has the invariants of §IV-C.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>
#include <vim/energy.hpp>
#include <vim/voxel_statistics.hpp>

#include "optimizer_test_util.hpp"
#include "primitives_test_util.hpp"

namespace vim {
namespace {

// ∫_box |x|² dx = Σ_a (hi_a³ − lo_a³)/3 · Π_{c≠a} (hi_c − lo_c).
template <int dim>
double integral_of_squared_norm(const Eigen::Matrix<double, dim, 1>& lo,
                                const Eigen::Matrix<double, dim, 1>& hi) {
  double total = 0.0;
  for (int a = 0; a < dim; ++a) {
    double term = (std::pow(hi[a], 3) - std::pow(lo[a], 3)) / 3.0;
    for (int c = 0; c < dim; ++c)
      if (c != a) term *= hi[c] - lo[c];
    total += term;
  }
  return total;
}

// Eq. 3: E_G = (1/(d+1)) Σ_i |x_i|² |Ω_i| − ∫_M |x|², Ω_i the 1-ring of node i.
template <int dim>
void expect_eq3(const Eigen::Matrix<double, dim, 1>& lo, const Eigen::Matrix<double, dim, 1>& hi,
                const std::array<int, dim>& n, unsigned seed) {
  std::mt19937 rng(seed);
  const auto mesh = testing::perturbed_grid_mesh<dim>(lo, hi, n, 0.3, rng);
  std::vector<double> ring_volume(mesh.n_points(), 0.0);
  double per_element = 0.0, volume = 0.0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    const double v = signed_volume<dim>(x);
    ASSERT_GT(v, 0.0);
    volume += v;
    for (int k : mesh.cells[c]) ring_volume[k] += v;
    per_element += geometric_energy<dim>(x);
  }
  double eq3 = 0.0;
  for (std::size_t i = 0; i < mesh.n_points(); ++i) eq3 += mesh.points[i].squaredNorm() * ring_volume[i];
  eq3 = eq3 / (dim + 1) - integral_of_squared_norm<dim>(lo, hi);
  EXPECT_NEAR(volume, (hi - lo).prod(), 1e-10 * (hi - lo).prod());
  EXPECT_GT(per_element, 0.0);
  EXPECT_NEAR(per_element, eq3, 1e-9 * std::abs(eq3) + 1e-12);
}

TEST(GeometricEnergy, SumEqualsOneRingFormOfEq3_2D) {
  expect_eq3<2>(Eigen::Vector2d(-1.0, 2.0), Eigen::Vector2d(3.0, 4.5), {7, 5}, 1);
  expect_eq3<2>(Eigen::Vector2d(10.0, -3.0), Eigen::Vector2d(11.0, 5.0), {3, 9}, 2);
}

TEST(GeometricEnergy, SumEqualsOneRingFormOfEq3_3D) {
  expect_eq3<3>(Eigen::Vector3d(-1.0, 2.0, 0.5), Eigen::Vector3d(3.0, 4.5, 2.0), {5, 4, 3}, 3);
  expect_eq3<3>(Eigen::Vector3d(5.0, 5.0, 5.0), Eigen::Vector3d(6.0, 7.0, 8.0), {3, 4, 5}, 4);
}

// ∫_τ f by the Duffy (collapsed-cube) map and 6-point Gauss–Legendre per axis: exact for the
// quadratic integrand times the polynomial Jacobian.
template <int dim, class F>
double duffy_quadrature(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, F f) {
  static const double gx[6] = {0.0337652428984240, 0.1693953067668677, 0.3806904069584015,
                               0.6193095930415985, 0.8306046932331323, 0.9662347571015760};
  static const double gw[6] = {0.0856622461895852, 0.1803807865240693, 0.2339569672863455,
                               0.2339569672863455, 0.1803807865240693, 0.0856622461895852};
  const double jac = std::abs(signed_volume<dim>(x)) * factorial(dim);  // |det| of the affine map
  double sum = 0.0;
  std::array<int, dim> q{};
  while (true) {
    // Reference point via collapse: λ_1 = u_1, λ_2 = u_2(1−u_1), λ_3 = u_3(1−u_1)(1−u_2).
    double rest = 1.0, w = 1.0;
    Eigen::Matrix<double, dim, 1> p = x[0];
    for (int a = 0; a < dim; ++a) {
      const double u = gx[q[a]];
      const double l = u * rest;
      p += l * (x[a + 1] - x[0]);
      w *= gw[q[a]] * rest;
      rest *= 1.0 - u;
    }
    // The Jacobian of the collapse is Π_a rest_a with rest_a = Π_{b<a}(1−u_b), accumulated in w.
    sum += w * f(p);
    int a = 0;
    for (; a < dim; ++a) {
      if (++q[a] < 6) break;
      q[a] = 0;
    }
    if (a == dim) break;
  }
  return sum * jac;
}

template <int dim>
void expect_quadrature(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3.0, 5.0);
  for (int t = 0; t < 20; ++t) {
    std::array<Eigen::Matrix<double, dim, 1>, dim + 1> x;
    for (auto& p : x)
      for (int a = 0; a < dim; ++a) p[a] = u(rng);
    // Linear interpolant of |x|² at the vertices, in barycentric coordinates.
    Eigen::Matrix<double, dim, dim> m;
    for (int k = 0; k < dim; ++k) m.col(k) = x[k + 1] - x[0];
    const Eigen::Matrix<double, dim, dim> inv = m.inverse();
    auto f = [&](const Eigen::Matrix<double, dim, 1>& p) {
      const Eigen::Matrix<double, dim, 1> l = inv * (p - x[0]);
      double interp = (1.0 - l.sum()) * x[0].squaredNorm();
      for (int k = 0; k < dim; ++k) interp += l[k] * x[k + 1].squaredNorm();
      return interp - p.squaredNorm();
    };
    const double ref = duffy_quadrature<dim>(x, f);
    EXPECT_NEAR(geometric_energy<dim>(x), ref, 1e-9 * std::abs(ref));
    // Volume check of the quadrature itself.
    EXPECT_NEAR(duffy_quadrature<dim>(x, [](const auto&) { return 1.0; }), std::abs(signed_volume<dim>(x)),
                1e-12 * (1.0 + std::abs(signed_volume<dim>(x))));
  }
}

TEST(GeometricEnergy, EqualsQuadratureOfInterpolationError2D) { expect_quadrature<2>(5); }
TEST(GeometricEnergy, EqualsQuadratureOfInterpolationError3D) { expect_quadrature<3>(6); }

TEST(GeometricEnergy, HandValuesAndDensityWeight) {
  // Unit right triangle: |τ| = 1/2, Σ|e|² = 1 + 1 + 2 = 4, E = 0.5·4/12 = 1/6.
  const std::array<Eigen::Vector2d, 3> t{Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
  EXPECT_NEAR(geometric_energy<2>(t), 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(geometric_energy<2>(t, 2.5), 2.5 / 6.0, 1e-15);
  // Unit corner tetrahedron: |τ| = 1/6, Σ|e|² = 3·1 + 3·2 = 9, E = (1/6)·9/20 = 3/40.
  const std::array<Eigen::Vector3d, 4> s{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                         Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1)};
  EXPECT_NEAR(geometric_energy<3>(s), 3.0 / 40.0, 1e-15);
  // Translation invariance.
  auto moved = s;
  for (auto& p : moved) p += Eigen::Vector3d(7, -2, 100);
  EXPECT_NEAR(geometric_energy<3>(moved), 3.0 / 40.0, 1e-12);
}

// A random image on a perturbed grid mesh; values and mesh as for the invariants below.
Image<2> random_image(unsigned seed) {
  Image<2> img({{23, 17}}, {{0.5, 0.5}}, {{0.25, 0.25}});  // box [0, 11.5] x [0, 8.5]
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(1.0, 9.0);
  for (auto& v : img.data) v = static_cast<float>(u(rng));
  return img;
}

// Truth: E_D = Σ_τ |τ|·var by brute force, the voxel centres of each element found by a barycentric
// test (testing::brute_force_owner) and their variance from the pairwise form
// var = (1/2n²) Σ_i Σ_k (h_i − h_k)², not the running sums the code uses.
TEST(DiscretizationEnergy, EqualsVolumeTimesPairwiseVarianceOfTheEnclosedVoxels) {
  const Image<2> img = random_image(3);
  std::mt19937 rng(4);
  const auto mesh = testing::perturbed_grid_mesh<2>(img.box_min(), img.box_max(), {{6, 5}}, 0.3, rng);
  const auto owner = testing::brute_force_owner(img, mesh);
  std::vector<std::vector<double>> enclosed(mesh.n_cells());
  for (std::size_t k = 0; k < owner.size(); ++k)
    if (owner[k] >= 0) enclosed[owner[k]].push_back(img.data[k]);
  const VoxelStatistics<2> stats(img);
  double brute = 0.0, code = 0.0;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    const auto& h = enclosed[c];
    ASSERT_GE(h.size(), 2u) << "cell " << c;
    double pairs = 0.0;
    for (double a : h)
      for (double b : h) pairs += (a - b) * (a - b);
    const double var = pairs / (2.0 * static_cast<double>(h.size() * h.size()));
    brute += std::abs(signed_volume<2>(x)) * var;
    code += discretization_energy(std::abs(signed_volume<2>(x)), stats.value(x).variance);
  }
  EXPECT_GT(brute, 0.0);
  EXPECT_NEAR(code, brute, 1e-9 * brute);
}

// Truth: the properties §IV-C gives the normalised E = (1−λ)E_G/E_G0 + λE_D/E_D0: it is 1 on the
// initial mesh for every λ; it does not change when the image values are scaled and shifted
// (h → 3h + 5) or the geometry is scaled (mesh and image by 2); with a constant image (E_D0 = 0) the
// image term is off, so E of two meshes are in the ratio of their E_G. E_G, E_D by brute force.
TEST(DiscretizationEnergy, NormalisedEnergyInvariants) {
  const Image<2> img = random_image(5);
  Image<2> affine = img, scaled = img, constant = img;
  for (auto& v : affine.data) v = 3.0f * v + 5.0f;
  for (int a = 0; a < 2; ++a) scaled.spacing[a] *= 2.0, scaled.origin[a] *= 2.0;
  for (auto& v : constant.data) v = 4.0f;
  std::mt19937 rng(6);
  const auto m0 = regular_grid_mesh<2>(img.box_min(), img.box_max(), {{6, 5}});
  const auto m1 = testing::perturbed_grid_mesh<2>(img.box_min(), img.box_max(), {{6, 5}}, 0.3, rng);
  auto doubled = [](SimplexMesh<2> m) {
    for (auto& p : m.points) p *= 2.0;
    return m;
  };
  for (const double lambda : {0.0, 0.3, 0.8}) {
    auto E = [&](const Image<2>& im, const SimplexMesh<2>& initial, const SimplexMesh<2>& m) {
      const auto e0 = testing::brute_force_energy(im, initial), e = testing::brute_force_energy(im, m);
      return EnergyNormalization{e0.eg, e0.ed, lambda}.combined(e.eg, e.ed);
    };
    EXPECT_NEAR(E(img, m0, m0), 1.0, 1e-12) << "lambda " << lambda;
    const double e1 = E(img, m0, m1);
    EXPECT_GT(std::abs(e1 - 1.0), 1e-3) << "the perturbed mesh must differ";
    EXPECT_NEAR(E(affine, m0, m1), e1, 1e-9 * e1) << "lambda " << lambda;
    EXPECT_NEAR(E(scaled, doubled(m0), doubled(m1)), e1, 1e-9 * e1) << "lambda " << lambda;
    const auto g0 = testing::brute_force_energy(constant, m0), g1 = testing::brute_force_energy(constant, m1);
    ASSERT_EQ(g0.ed, 0.0);
    const EnergyNormalization off{g0.eg, g0.ed, lambda};
    EXPECT_NEAR(off.combined(g1.eg, 123.0) / off.combined(g0.eg, 0.0), g1.eg / g0.eg, 1e-12)
        << "lambda " << lambda;
  }
}

}  // namespace
}  // namespace vim

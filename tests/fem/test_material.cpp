// Tests for the material of fem/ (fem/src/linear_elastic_material.hpp) against independent truth: the
// stress of a random strain against a hand-written isotropic Hooke's law with the textbook Lamé
// parameters, the energy density against ½ σ:ε, the tangent against σ = C:ε, and the element matrices
// the model assembles (P1 simplices, Q1 voxels) against the ones built by brute force from the
// material's tangent tensor: K_ij = ∫ ∂_k N_i C_{a k b l} ∂_l N_j.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <sstream>
#include <vim/fem/elasticity.hpp>
#include <vim/fem/material_description.hpp>

#include "../../fem/src/linear_elastic_material.hpp"

using namespace vim;
using namespace vim::fem;

namespace {

// Textbook isotropic Hooke's law, written out component by component (not the material's code).
template <int dim>
Eigen::Matrix<double, dim, dim> hooke(double E, double nu, const Eigen::Matrix<double, dim, dim>& eps) {
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  Eigen::Matrix<double, dim, dim> s;
  for (int i = 0; i < dim; ++i)
    for (int j = 0; j < dim; ++j) {
      s(i, j) = 2 * mu * eps(i, j);
      if (i == j)
        for (int k = 0; k < dim; ++k) s(i, j) += lambda * eps(k, k);
    }
  return s;
}

template <int dim>
dealii::Tensor<2, dim> to_tensor(const Eigen::Matrix<double, dim, dim>& a) {
  dealii::Tensor<2, dim> t;
  for (int i = 0; i < dim; ++i)
    for (int j = 0; j < dim; ++j) t[i][j] = a(i, j);
  return t;
}

template <int dim>
void stress_energy_and_tangent(double nu) {
  std::mt19937 rng(11 + dim);
  std::uniform_real_distribution<double> U(-1.0, 1.0), P(0.5, 50.0);
  std::vector<double> E(5);
  for (double& e : E) e = P(rng);
  const LinearElasticMaterial<dim> material(E, nu);
  const Material<dim>& law = material;  // the generic interface
  EXPECT_TRUE(law.small_strain());
  for (unsigned j = 0; j < E.size(); ++j) {
    Eigen::Matrix<double, dim, dim> H;
    for (int a = 0; a < dim; ++a)
      for (int b = 0; b < dim; ++b) H(a, b) = U(rng);
    const Eigen::Matrix<double, dim, dim> eps = 0.5 * (H + H.transpose()), truth = hooke<dim>(E[j], nu, eps);
    const double scale = truth.norm();
    // the kernels' form (Eigen) and the interface's (of ∇u: the rotation part gives no stress)
    const Eigen::Matrix<double, dim, dim> s = LinearElasticMaterial<dim>::stress(material.cell(j), eps);
    const dealii::Tensor<2, dim> sg = law.stress(j, to_tensor<dim>(H));
    for (int a = 0; a < dim; ++a)
      for (int b = 0; b < dim; ++b) {
        EXPECT_NEAR(s(a, b), truth(a, b), 1e-14 * scale);
        EXPECT_NEAR(sg[a][b], truth(a, b), 1e-14 * scale);
      }
    // energy density ½ σ:ε
    const double w = 0.5 * (truth.array() * eps.array()).sum();
    EXPECT_NEAR(law.energy_density(j, to_tensor<dim>(H)), w, 1e-14 * std::abs(w) + 1e-14 * scale);
    // tangent: C : ∇u = σ, and C has the major and minor symmetries
    const dealii::Tensor<4, dim> C = law.tangent(j, to_tensor<dim>(H));
    for (int a = 0; a < dim; ++a)
      for (int b = 0; b < dim; ++b) {
        double v = 0;
        for (int k = 0; k < dim; ++k)
          for (int l = 0; l < dim; ++l) {
            v += C[a][b][k][l] * H(k, l);
            EXPECT_EQ(C[a][b][k][l], C[k][l][a][b]);
            EXPECT_EQ(C[a][b][k][l], C[b][a][k][l]);
          }
        EXPECT_NEAR(v, truth(a, b), 1e-14 * scale);
      }
    // plane strain: σ_zz = ν (σ_xx + σ_yy) = λ tr ε
    if (dim == 2) {
      EXPECT_NEAR(LinearElasticMaterial<dim>::out_of_plane_stress(material.cell(j), eps), nu * truth.trace(),
                  1e-14 * scale);
    }
  }
}

TEST(Material, StressEnergyAndTangentMatchHookesLaw2D) { stress_energy_and_tangent<2>(0.3); }
TEST(Material, StressEnergyAndTangentMatchHookesLaw3D) { stress_energy_and_tangent<3>(0.45); }
TEST(Material, StressEnergyAndTangentMatchHookesLawAuxetic) { stress_energy_and_tangent<3>(-0.4); }

TEST(Material, LameParametersAndBadInput) {
  const double E = 3.7, nu = 0.31;
  const Lame<> c = LinearElasticMaterial<3>::lame(E, nu);
  EXPECT_NEAR(c.lambda, E * nu / ((1 + nu) * (1 - 2 * nu)), 1e-15 * E);
  EXPECT_NEAR(c.mu, E / (2 * (1 + nu)), 1e-15 * E);
  EXPECT_NEAR(LinearElasticMaterial<3>::shear_modulus(E, nu), E / (2 * (1 + nu)), 1e-15 * E);
  EXPECT_EQ(lame_parameters(E, nu), std::make_pair(c.lambda, c.mu));  // the public form of the same
  EXPECT_THROW(LinearElasticMaterial<3>::lame(0.0, nu), std::invalid_argument);
  EXPECT_THROW(LinearElasticMaterial<3>::lame(std::nan(""), nu), std::invalid_argument);
  EXPECT_THROW(LinearElasticMaterial<3>::lame(E, 0.5), std::invalid_argument);
  EXPECT_THROW(LinearElasticMaterial<3>::lame(E, -1.0), std::invalid_argument);
}

// The element matrix of a one-cell model from its energies: K_ab = W(e_a + e_b) − W(e_a) − W(e_b),
// K_aa = 2 W(e_a), with W = strain_energy_of (½ uᵀ K u); DoF a = dim·vertex + component.
template <int dim>
Eigen::MatrixXd element_matrix_from_energies(const ElasticModel<dim>& model) {
  const std::size_t nv = model.vertices().size(), n = nv * dim;
  auto energy = [&](std::size_t a, std::size_t b) {
    std::vector<Vec<dim>> u(nv, Vec<dim>::Zero());
    u[a / dim][a % dim] += 1.0;
    u[b / dim][b % dim] += 1.0;
    return model.strain_energy_of(u);
  };
  Eigen::VectorXd diag(n);
  for (std::size_t a = 0; a < n; ++a) diag[a] = 0.25 * energy(a, a);  // u = 2 e_a: W = 2 K_aa
  Eigen::MatrixXd K(n, n);
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) K(a, b) = a == b ? 2 * diag[a] : energy(a, b) - diag[a] - diag[b];
  return K;
}

// Σ over points of weight · ∂_k N_i C_{a k b l} ∂_l N_j, C from the material's generic tangent.
template <int dim>
void add_brute_force(const dealii::Tensor<4, dim>& C, const std::vector<Vec<dim>>& grad, double weight,
                     Eigen::MatrixXd& K) {
  for (std::size_t i = 0; i < grad.size(); ++i)
    for (std::size_t j = 0; j < grad.size(); ++j)
      for (int a = 0; a < dim; ++a)
        for (int b = 0; b < dim; ++b) {
          double v = 0;
          for (int k = 0; k < dim; ++k)
            for (int l = 0; l < dim; ++l) v += grad[i][k] * C[a][k][b][l] * grad[j][l];
          K(i * dim + a, j * dim + b) += weight * v;
        }
}

template <int dim>
void p1_element_matrix_is_the_tangents() {
  std::mt19937 rng(5 + dim);
  std::uniform_real_distribution<double> U(-0.3, 0.3);
  SimplexMesh<dim> mesh;
  mesh.points.assign(dim + 1, Vec<dim>::Zero());
  for (int d = 0; d < dim; ++d) mesh.points[d + 1][d] = 1.0;
  for (auto& p : mesh.points)
    for (int d = 0; d < dim; ++d) p[d] += U(rng);
  typename SimplexMesh<dim>::Cell cell;
  for (int k = 0; k <= dim; ++k) cell[k] = k;
  mesh.cells = {cell};
  ASSERT_GT(signed_volume(mesh, 0), 0.0);
  const std::vector<double> E{2.9};
  const double nu = 0.37;
  const ElasticModel<dim> model(mesh, E, nu, 1);
  // barycentric gradients: rows of the inverse of [x_1 − x_0, …, x_d − x_0]
  Eigen::Matrix<double, dim, dim> X;
  for (int d = 0; d < dim; ++d) X.col(d) = mesh.points[d + 1] - mesh.points[0];
  const Eigen::Matrix<double, dim, dim> Xi = X.inverse();
  std::vector<Vec<dim>> g(dim + 1);
  g[0] = -Xi.colwise().sum().transpose();
  for (int d = 0; d < dim; ++d) g[d + 1] = Xi.row(d).transpose();
  Eigen::MatrixXd truth = Eigen::MatrixXd::Zero((dim + 1) * dim, (dim + 1) * dim);
  const LinearElasticMaterial<dim> material(E, nu);
  add_brute_force<dim>(static_cast<const Material<dim>&>(material).tangent(0, {}), g, signed_volume(mesh, 0),
                       truth);
  const Eigen::MatrixXd K = element_matrix_from_energies<dim>(model);
  EXPECT_LT((K - truth).norm(), 1e-12 * truth.norm()) << "assembled\n" << K << "\nbrute force\n" << truth;
}

TEST(Material, AssembledP1ElementMatrixIsTheTangentsBruteForce2D) { p1_element_matrix_is_the_tangents<2>(); }
TEST(Material, AssembledP1ElementMatrixIsTheTangentsBruteForce3D) { p1_element_matrix_is_the_tangents<3>(); }

// One voxel (box h), Q1: N_v = Π_d (bit_d(v) ? ξ_d : 1 − ξ_d), 2^dim Gauss points; vertices in the
// grid's order (axis 0 fastest).
template <int dim>
void voxel_element_matrix_is_the_tangents() {
  Vec<dim> h;
  for (int d = 0; d < dim; ++d) h[d] = 0.5 + 0.25 * d;
  const std::vector<double> E{4.2};
  const double nu = 0.28;
  std::array<long, dim> cells;
  cells.fill(1);
  const auto model = ElasticModel<dim>::voxel_grid(cells, Vec<dim>::Zero(), h, E, nu);
  constexpr int nv = 1 << dim;
  const LinearElasticMaterial<dim> material(E, nu);
  const dealii::Tensor<4, dim> C = static_cast<const Material<dim>&>(material).tangent(0, {});
  Eigen::MatrixXd truth = Eigen::MatrixXd::Zero(nv * dim, nv * dim);
  const double gauss[2] = {0.5 - 0.5 / std::sqrt(3.0), 0.5 + 0.5 / std::sqrt(3.0)};
  double volume = 1.0;
  for (int d = 0; d < dim; ++d) volume *= h[d];
  for (int q = 0; q < nv; ++q) {
    std::vector<Vec<dim>> grad(nv);
    for (int v = 0; v < nv; ++v)
      for (int k = 0; k < dim; ++k) {
        double value = 1.0;
        for (int d = 0; d < dim; ++d) {
          const double xi = gauss[(q >> d) & 1];
          const bool up = (v >> d) & 1;
          value *= d == k ? (up ? 1.0 : -1.0) / h[d] : (up ? xi : 1.0 - xi);
        }
        grad[v][k] = value;
      }
    add_brute_force<dim>(C, grad, volume / nv, truth);
  }
  for (int v = 0; v < nv; ++v)
    for (int d = 0; d < dim; ++d) ASSERT_NEAR(model.vertices()[v][d], (v >> d) & 1 ? h[d] : 0.0, 1e-15);
  const Eigen::MatrixXd K = element_matrix_from_energies<dim>(model);
  EXPECT_LT((K - truth).norm(), 1e-12 * truth.norm()) << "assembled\n" << K << "\nbrute force\n" << truth;
}

TEST(Material, AssembledVoxelElementMatrixIsTheTangentsBruteForce2D) {
  voxel_element_matrix_is_the_tangents<2>();
}
TEST(Material, AssembledVoxelElementMatrixIsTheTangentsBruteForce3D) {
  voxel_element_matrix_is_the_tangents<3>();
}

// The solver decks' material cards.
TEST(Material, DescriptionWritesTheDeckCards) {
  const MaterialDescription material{0.45};
  std::ostringstream inp, feb;
  material.write_inp_card(inp, 12.5);
  EXPECT_EQ(inp.str(), "*Elastic\n12.5, 0.45\n");
  material.write_feb_material(feb, 1, "tissue", "E_map");
  EXPECT_EQ(feb.str(),
            "    <material id=\"1\" name=\"tissue\" type=\"isotropic elastic\">\n      <density>1</density>\n"
            "      <E type=\"map\">E_map</E>\n      <v>0.45</v>\n    </material>\n");
}

}  // namespace

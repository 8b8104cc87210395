// Tests for the finite-strain solve (vim/fem/finite_strain.hpp, fem/src/neo_hookean_material.hpp)
// against independent truth: the first Piola stress of W = C10 (Ī₁ − 3) + (J − 1)²/D₁ written out by
// hand for homogeneous deformations (uniaxial stretch with free lateral faces, its lateral stretch from
// a scalar root find of P₂₂ = 0; simple shear), the linear solution at small load, finite differences
// of the energy, the stress and the assembled residual, and a rigid rotation.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vim/fem/finite_strain.hpp>
#include <vim/fem/model.hpp>

#include "../../fem/src/neo_hookean_material.hpp"
#include "box_mesh.hpp"

using namespace vim;
using namespace vim::fem;

namespace {

constexpr double kE = 10.0;

struct Constants {
  double c10, d1;
};
// C10 = μ/2, D₁ = 2/K, written from the textbook μ and K (not the material's code).
Constants constants(double E, double nu) { return {E / (4 * (1 + nu)), 6 * (1 - 2 * nu) / E}; }

// ∂W/∂λ_i of W(diag(λ₁, λ₂, λ₃)) = C10 (J^(−2/3)(λ₁² + λ₂² + λ₃²) − 3) + (J − 1)²/D₁, J = λ₁λ₂λ₃.
double principal_piola(const Constants& c, const std::array<double, 3>& l, int i) {
  const double J = l[0] * l[1] * l[2], I1 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  return c.c10 * std::pow(J, -2.0 / 3.0) * (2 * l[i] - (2.0 / 3.0) * I1 / l[i]) +
         2 * (J - 1) * J / (c.d1 * l[i]);
}

// The lateral stretch of uniaxial stress: P₂₂(λ₁, λ₂, λ₂) = 0, by bisection.
double lateral_stretch(const Constants& c, double l1) {
  double lo = 0.2, hi = 3.0;
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (principal_piola(c, {{l1, mid, mid}}, 1) > 0 ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

template <int dim>
DirichletBC<dim> face_bc(int axis, bool upper, int component, double value) {
  DirichletBC<dim> bc;
  bc.region = box_face_region<dim>(Vec<dim>::Zero(), Vec<dim>::Ones(), axis, upper, 1e-9);
  bc.components = DirichletBC<dim>::filled(false);
  bc.components[component] = true;
  bc.value = Vec<dim>::Unit(component) * value;
  return bc;
}

// The unit cube, 2×2×2 Kuhn cells (6 tetrahedra each), E = kE.
ElasticModel<3> cube(unsigned degree, double nu, int cells = 2) {
  const SimplexMesh<3> mesh = test::kuhn_box<3>({{cells, cells, cells}}, {{0, 0, 0}}, {{1, 1, 1}});
  return ElasticModel<3>(mesh, std::vector<double>(mesh.cells.size(), kE), nu, degree);
}

// Uniaxial stretch λ₁ of the unit cube: x = 1 moved to λ₁, symmetry planes x = 0, y = 0, z = 0, the
// faces y = 1 and z = 1 free. The reaction on x = 1 is P₁₁ · 1 and the face y = 1 moves by λ₂ − 1.
void uniaxial(unsigned degree, double l1, double nu) {
  ElasticModel<3> model = cube(degree, nu);
  model.add_dirichlet(face_bc<3>(0, true, 0, l1 - 1));
  for (int d = 0; d < 3; ++d) model.add_dirichlet(face_bc<3>(d, false, d, 0.0));
  NewtonOptions opt;
  opt.initial_steps = 2;
  const FiniteStrainSolution<3> r = solve_neo_hookean(model, opt);
  const Constants c = constants(kE, nu);
  const double l2 = lateral_stretch(c, l1), P11 = principal_piola(c, {{l1, l2, l2}}, 0);
  EXPECT_NEAR(r.solution.dirichlet_reaction[0][0], P11, 1e-3 * std::abs(P11)) << "λ1 " << l1;
  for (std::size_t v = 0; v < model.vertices().size(); ++v)
    for (int d = 1; d < 3; ++d)
      EXPECT_NEAR(r.solution.vertex_displacement[v][d], (l2 - 1) * model.vertices()[v][d],
                  1e-3 * std::abs(l2 - 1));
  ASSERT_FALSE(r.steps.empty());
  for (const LoadStepRecord& s : r.steps) {
    ASSERT_EQ(s.residual_norm.size(), s.update_norm.size() + 1);
    EXPECT_LE(s.residual_norm.back(), 1e-10 * s.residual_norm.front());
  }
  EXPECT_DOUBLE_EQ(r.steps.back().load_factor, 1.0);
}

// Simple shear F = I + γ e₁⊗e₂ held on the whole boundary; the face y = 1 is the first condition. Its
// reaction is ∫ P·N over it, plus P_i1 times the difference of the shape-function strips on x = 1 and
// x = 0, which the Kuhn mesh (the same cell split at every face) makes 0: (P₁₂, P₂₂, 0) = (μγ, −μγ²/3, 0)
// (J = 1, Ī₁ = 3 + γ²).
void simple_shear(unsigned degree, double gamma) {
  const double nu = 0.3;
  ElasticModel<3> model = cube(degree, nu);
  DirichletBC<3> top;
  top.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>::Ones(), 1, true, 1e-9);
  top.value = Vec<3>(gamma, 0, 0);
  model.add_dirichlet(top);
  DirichletBC<3> rest;
  rest.region = {"boundary",
                 [](const Vec<3>& x) { return (x.array() < 1e-9).any() || (x.array() > 1 - 1e-9).any(); }};
  rest.function = [gamma](const Vec<3>& x) { return Vec<3>(gamma * x[1], 0, 0); };
  model.add_dirichlet(rest);
  const FiniteStrainSolution<3> r = solve_neo_hookean(model);
  const double mu = kE / (2 * (1 + nu));
  const Vec<3> truth(mu * gamma, -mu * gamma * gamma / 3, 0);
  EXPECT_NEAR(r.solution.dirichlet_reaction[0][0], truth[0], 1e-3 * std::abs(truth[0]));
  EXPECT_NEAR(r.solution.dirichlet_reaction[0][1], truth[1], 1e-3 * std::abs(truth[1]));
  EXPECT_NEAR(r.solution.dirichlet_reaction[0][2], 0.0, 1e-3 * std::abs(truth[1]));
}

}  // namespace

TEST(NeoHookeanMaterial, StressAndTangentAreDerivativesAndMatchLinearAtIdentity) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-0.3, 0.3);
  const std::vector<double> E{kE, 3.0};
  const double nu = 0.35;
  const NeoHookeanMaterial<3> law(E, nu);
  dealii::Tensor<2, 3> H;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) H[a][b] = U(rng);
  const double h = 1e-6;
  const dealii::Tensor<2, 3> P = law.stress(1, H);
  const dealii::Tensor<4, 3> A = law.tangent(1, H);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      dealii::Tensor<2, 3> Hp = H, Hm = H;
      Hp[a][b] += h, Hm[a][b] -= h;
      EXPECT_NEAR(P[a][b], (law.energy_density(1, Hp) - law.energy_density(1, Hm)) / (2 * h), 1e-6 * E[1]);
      const dealii::Tensor<2, 3> dP = (law.stress(1, Hp) - law.stress(1, Hm)) / (2 * h);
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d) EXPECT_NEAR(A[c][d][a][b], dP[c][d], 1e-6 * E[1]);
    }
  // At F = I: C = λ δδ + μ (δδ + δδ) with the textbook λ, μ of (E, ν).
  const dealii::Tensor<4, 3> C = law.tangent(0, dealii::Tensor<2, 3>());
  const double lambda = kE * nu / ((1 + nu) * (1 - 2 * nu)), mu = kE / (2 * (1 + nu));
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d)
          EXPECT_NEAR(C[a][b][c][d],
                      (a == b && c == d) * lambda + ((a == c && b == d) + (a == d && b == c)) * mu,
                      1e-12 * kE);
}

TEST(NeoHookean, UniaxialCompressionP1) { uniaxial(1, 0.7, 0.3); }
TEST(NeoHookean, UniaxialStretchP1) { uniaxial(1, 1.5, 0.3); }
TEST(NeoHookean, UniaxialCompressionP2) { uniaxial(2, 0.7, 0.45); }
TEST(NeoHookean, UniaxialStretchP2) { uniaxial(2, 1.5, 0.45); }
TEST(NeoHookean, SimpleShearP1) { simple_shear(1, 0.5); }
TEST(NeoHookean, SimpleShearP2) { simple_shear(2, 0.5); }

// At 1e-4 of the loads above (strains of 3e-5: a pressure on x = 1 of a two-modulus bar clamped at
// x = 0, and its end pushed in by 1e-4 of λ₁ = 0.7), the finite-strain displacement equals the linear
// one within 1e-4 relative.
TEST(NeoHookean, SmallStrainLimitEqualsLinear) {
  for (const unsigned degree : {1u, 2u}) {
    const SimplexMesh<3> mesh = test::kuhn_box<3>({{4, 2, 2}}, {{0, 0, 0}}, {{2, 1, 1}});
    std::vector<double> E(mesh.cells.size());
    for (std::size_t c = 0; c < E.size(); ++c) E[c] = mesh.points[mesh.cells[c][0]][0] < 0.99 ? kE : 3 * kE;
    for (const bool pressure : {true, false}) {
      ElasticModel<3> model(mesh, E, 0.3, degree);
      DirichletBC<3> clamp;
      clamp.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>(2, 1, 1), 0, false, 1e-9);
      model.add_dirichlet(clamp);
      const Region<3> end = box_face_region<3>(Vec<3>::Zero(), Vec<3>(2, 1, 1), 0, true, 1e-9);
      if (pressure) {
        model.add_surface_load({end, Vec<3>::Zero(), 1e-4 * 0.3 * kE});
      } else {
        DirichletBC<3> pull;
        pull.region = end;
        pull.components = {{true, false, false}};
        pull.value = Vec<3>(2 * 1e-4 * -0.3, 0, 0);
        model.add_dirichlet(pull);
      }
      const Solution<3> lin = model.solve();
      const FiniteStrainSolution<3> nl = solve_neo_hookean(model);
      double diff = 0, scale = 0;
      for (std::size_t v = 0; v < lin.vertex_displacement.size(); ++v) {
        diff = std::max(diff, (nl.solution.vertex_displacement[v] - lin.vertex_displacement[v]).norm());
        scale = std::max(scale, lin.vertex_displacement[v].norm());
      }
      EXPECT_GT(scale, 1e-6);
      EXPECT_LT(diff, 1e-4 * scale) << "degree " << degree << " pressure " << pressure;
    }
  }
}

// The assembled tangent against central differences of the assembled residual at a random state
// (P2 tetrahedra and P1 triangles in plane strain, random moduli, a volume support and a pressure).
template <int dim>
void tangent_check(unsigned degree) {
  std::array<int, dim> cells;
  std::array<double, dim> lo, hi;
  cells.fill(1), lo.fill(0.0), hi.fill(1.0);
  cells[0] = 2;
  const SimplexMesh<dim> mesh = test::kuhn_box<dim>(cells, lo, hi);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> Em(2.0, 20.0), amp(-0.05, 0.05);
  std::vector<double> E(mesh.cells.size());
  for (double& e : E) e = Em(rng);
  ElasticModel<dim> model(mesh, E, 0.4, degree);
  DirichletBC<dim> clamp;
  clamp.region = box_face_region<dim>(Vec<dim>::Zero(), Vec<dim>::Ones(), 0, false, 1e-9);
  model.add_dirichlet(clamp);
  model.add_surface_load(
      {box_face_region<dim>(Vec<dim>::Zero(), Vec<dim>::Ones(), 1, true, 1e-9), Vec<dim>::Zero(), 0.5});
  model.add_volume_support({"spring", {Vec<dim>::Constant(0.5)}, {0.1}, 30.0, {}});
  const unsigned n = model.n_dofs();
  Eigen::VectorXd u(n);
  for (unsigned i = 0; i < n; ++i) u[i] = amp(rng);
  Eigen::VectorXd r, rp, rm;
  Eigen::MatrixXd K, Kp;
  neo_hookean_system<dim>(model, u, 0.7, r, K);
  const double h = 1e-6;
  Eigen::MatrixXd fd(n, n);
  for (unsigned j = 0; j < n; ++j) {
    Eigen::VectorXd up = u, um = u;
    up[j] += h, um[j] -= h;
    neo_hookean_system<dim>(model, up, 0.7, rp, Kp);
    neo_hookean_system<dim>(model, um, 0.7, rm, Kp);
    fd.col(j) = (rp - rm) / (2 * h);
  }
  const double scale = K.cwiseAbs().maxCoeff();
  EXPECT_LT((K - fd).cwiseAbs().maxCoeff(), 1e-6 * scale);
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);
}
TEST(NeoHookean, TangentMatchesCentralDifferencesP2_3D) { tangent_check<3>(2); }
TEST(NeoHookean, TangentMatchesCentralDifferencesP1_2D) { tangent_check<2>(1); }

// A rotation by 90° about z prescribed on the face x = 0 of an otherwise free cube: the
// finite-strain solid turns rigidly (stress below 1e-8 E), the linear one is strained by
// sym(R − I) = −(e₁e₁ + e₂e₂) and carries stress of the order of E.
TEST(NeoHookean, RigidRotationIsStressFreeUnlikeLinear) {
  for (const unsigned degree : {1u, 2u}) {
    ElasticModel<3> model = cube(degree, 0.3, 1);
    DirichletBC<3> turn;
    turn.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>::Ones(), 0, false, 1e-9);
    turn.function = [](const Vec<3>& x) { return Vec<3>(-x[1] - x[0], x[0] - x[1], 0); };
    model.add_dirichlet(turn);
    const Solution<3> lin = model.solve();
    NewtonOptions opt;
    opt.initial_steps = 4;
    const FiniteStrainSolution<3> nl = solve_neo_hookean(model, opt);
    double lin_max = 0, nl_max = 0;
    for (std::size_t c = 0; c < lin.cell_stress.size(); ++c) {
      lin_max = std::max(lin_max, lin.cell_stress[c].cwiseAbs().maxCoeff());
      nl_max = std::max(nl_max, nl.solution.cell_stress[c].cwiseAbs().maxCoeff());
    }
    EXPECT_GT(lin_max, 0.1 * kE);
    EXPECT_LT(nl_max, 1e-8 * kE) << "degree " << degree;
    // every vertex turned: x ↦ R x
    for (std::size_t v = 0; v < model.vertices().size(); ++v) {
      const Vec<3>& x = model.vertices()[v];
      EXPECT_NEAR((x + nl.solution.vertex_displacement[v] - Vec<3>(-x[1], x[0], x[2])).norm(), 0.0, 1e-9);
    }
  }
}

// A load step that cannot converge (one Newton iteration allowed, two halvings) ends in an error
// naming the step's load factors.
TEST(NeoHookean, StepThatCannotConvergeIsNamed) {
  ElasticModel<3> model = cube(1, 0.3);
  model.add_dirichlet(face_bc<3>(0, true, 0, 0.5));
  for (int d = 0; d < 3; ++d) model.add_dirichlet(face_bc<3>(d, false, d, 0.0));
  NewtonOptions opt;
  opt.max_iterations = 1;
  opt.max_halvings = 2;
  try {
    solve_neo_hookean(model, opt);
    FAIL() << "no error";
  } catch (const NewtonFailure& e) {
    EXPECT_NE(std::string(e.what()).find("load step from load factor 0 to 0.25"), std::string::npos)
        << e.what();
  }
}

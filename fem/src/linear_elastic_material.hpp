// The material of fem/: linear isotropic elasticity with a Young's modulus E_j per cell and one Poisson
// ratio ν, plane strain in 2D. This is the one file of fem/ that holds the Lamé parameters and the
// stress law: the element kernels (P1, the P2 quadrature, the voxel Q1 split K_e = λ Kλ + μ Kμ, the
// matrix-free voxel operator), the post-processing (centroid stress, von Mises) and the closed-form
// needle formulas (shear modulus) take λ, μ, σ and the tangent from here; the public, deal.II-free
// description that the solver decks write is vim/fem/material_description.hpp.
//
// The interface of a material is Material<dim> below: per cell, the stress at a displacement gradient
// H = ∇u, its tangent ∂stress/∂H and the strain energy density. A small-strain law reads ε = sym H
// and returns the Cauchy stress; a finite-strain law reads F = I + H and returns the first
// Piola–Kirchhoff stress P(F) with the tangent A = ∂P/∂F, which is what a Newton solve assembles
// (residual ∫ P : ∇v, tangent ∫ ∇v : A : ∇δu). A compressible neo-Hookean material (deal.II step-44)
// is one more file like this one, deriving from Material<dim>, plus a Newton path in the solvers
// (docs/architecture.md, fem module, "Add a material"). The linear kernels do not go through the
// virtual interface: they hold the per-cell constants (Lame) from cell()/of_modulus() and call the
// static inline laws (stiffness, stiffness_parts, stress), so the assembly keeps its loops.
#pragma once

#include <deal.II/base/symmetric_tensor.h>
#include <deal.II/base/tensor.h>
#include <deal.II/base/vectorization.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "input_checks.hpp"

namespace vim::fem {

// The constants of one cell's linear law, as the kernels hold them: λ and μ. Number is double, or a
// deal.II VectorizedArray for the cell batches of the matrix-free operator (set lane by lane).
template <typename Number = double>
struct Lame {
  Number lambda = Number(), mu = Number();
  void set_lane(unsigned lane, const Lame<double>& c) {
    lambda[lane] = static_cast<typename Number::value_type>(c.lambda);
    mu[lane] = static_cast<typename Number::value_type>(c.mu);
  }
};

// A material: the constitutive law of every cell of a model. `cell` is the input cell index (the
// material_id of a deal.II cell); grad_u is H = ∇u at the point.
template <int dim>
class Material {
 public:
  virtual ~Material() = default;
  // True for a small-strain law (stress linear in ε = sym H: one linear solve), false for a
  // finite-strain law (stress of F = I + H: a Newton solve).
  virtual bool small_strain() const = 0;
  // Small strain: the Cauchy stress σ(ε). Finite strain: the first Piola–Kirchhoff stress P(F).
  virtual dealii::Tensor<2, dim> stress(unsigned cell, const dealii::Tensor<2, dim>& grad_u) const = 0;
  // ∂stress/∂H at grad_u: the elasticity tensor C (small strain, independent of grad_u), or ∂P/∂F.
  // The stiffness of the vector shape functions e_a N_i, e_b N_j is Σ_kl ∂_k N_i tangent_akbl ∂_l N_j.
  virtual dealii::Tensor<4, dim> tangent(unsigned cell, const dealii::Tensor<2, dim>& grad_u) const = 0;
  // Strain energy per (reference) volume at grad_u: ½ σ : ε for the linear law.
  virtual double energy_density(unsigned cell, const dealii::Tensor<2, dim>& grad_u) const = 0;
};

// Linear isotropic elasticity: σ = λ tr(ε) I + 2μ ε, λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)) per cell.
// A view: it refers to the per-cell moduli, which must outlive it.
template <int dim>
class LinearElasticMaterial final : public Material<dim> {
 public:
  LinearElasticMaterial(const std::vector<double>& youngs_modulus, double poisson_ratio)
      : E_(&youngs_modulus), nu_(poisson_ratio) {}

  // ---- the Lamé parameters (the same in 2D: plane strain) -------------------------------------
  // μ = G = E/(2(1+ν)), unchecked (also the closed-form needle formulas).
  static double shear_modulus(double E, double nu) { return E / (2.0 * (1.0 + nu)); }
  // {λ, μ}; std::invalid_argument for E not finite/> 0 or ν outside (−1, 0.5).
  static Lame<> lame(double E, double nu) {
    if (!std::isfinite(E) || !(E > 0.0)) {
      std::ostringstream m;
      m << "Young's modulus must be finite and > 0, got " << E;
      throw std::invalid_argument(m.str());
    }
    check_poisson_ratio(nu);
    return {E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), shear_modulus(E, nu)};
  }
  // The constants of input cell j, and of a cell of modulus E (a coarse multigrid cell: a mean).
  Lame<> cell(unsigned j) const { return lame((*E_)[j], nu_); }
  Lame<> of_modulus(double E) const { return lame(E, nu_); }
  double poisson_ratio() const { return nu_; }

  // ---- the tangent, contracted with shape-function gradients -----------------------------------
  // ∇(e_ci N_i) : C : ∇(e_cj N_j) for shape gradients gi, gj: the element stiffness integrand.
  static double stiffness(const Lame<>& c, const dealii::Tensor<1, dim>& gi, unsigned ci,
                          const dealii::Tensor<1, dim>& gj, unsigned cj) {
    double v = c.lambda * gi[ci] * gj[cj] + c.mu * gi[cj] * gj[ci];
    if (ci == cj) v += c.mu * (gi * gj);
    return v;
  }
  // The same split by constant, C = λ C_λ + μ C_μ: {∇ : C_λ : ∇, ∇ : C_μ : ∇}, for congruent cells
  // whose two reference matrices are integrated once (voxels) and combined per cell by combine().
  static std::array<double, 2> stiffness_parts(const dealii::Tensor<1, dim>& gi, unsigned ci,
                                               const dealii::Tensor<1, dim>& gj, unsigned cj) {
    return {{gi[ci] * gj[cj], gi[cj] * gj[ci] + (ci == cj ? gi * gj : 0.0)}};
  }
  static double combine(const Lame<>& c, double part_lambda, double part_mu) {
    return c.lambda * part_lambda + c.mu * part_mu;
  }

  // ---- the stress law -------------------------------------------------------------------------
  // σ = 2μ ε + λ tr(ε) I of an Eigen dim×dim strain (post-processing).
  static Eigen::Matrix<double, dim, dim> stress(const Lame<>& c, const Eigen::Matrix<double, dim, dim>& eps) {
    const double tr = eps.trace();
    Eigen::Matrix<double, dim, dim> sigma = 2.0 * c.mu * eps;
    for (int d = 0; d < dim; ++d) sigma(d, d) += c.lambda * tr;
    return sigma;
  }
  // σ_zz of the plane strain of a 2D model (ε_zz = 0): λ tr(ε).
  static double out_of_plane_stress(const Lame<>& c, const Eigen::Matrix<double, dim, dim>& eps) {
    return c.lambda * eps.trace();
  }
  // σ = 2μ ε + λ tr(ε) I in deal.II's types, tr(ε) given (the divergence the matrix-free operator has).
  // 2μ is μ + μ: the same value as 2·μ, for any Number.
  template <typename Number>
  static dealii::SymmetricTensor<2, dim, Number> stress(const Lame<Number>& c,
                                                        const dealii::SymmetricTensor<2, dim, Number>& eps,
                                                        const Number& trace) {
    dealii::SymmetricTensor<2, dim, Number> sigma = (c.mu + c.mu) * eps;
    const Number pressure = c.lambda * trace;
    for (int d = 0; d < dim; ++d) sigma[d][d] += pressure;
    return sigma;
  }
  // C_abkl = λ δ_ab δ_kl + μ (δ_ak δ_bl + δ_al δ_bk).
  static dealii::SymmetricTensor<4, dim> elasticity_tensor(const Lame<>& c) {
    dealii::SymmetricTensor<4, dim> C;
    for (unsigned a = 0; a < dim; ++a)
      for (unsigned b = a; b < dim; ++b)
        for (unsigned k = 0; k < dim; ++k)
          for (unsigned l = k; l < dim; ++l)
            C[a][b][k][l] = (a == b && k == l ? c.lambda : 0.0) + (a == k && b == l ? c.mu : 0.0) +
                            (a == l && b == k ? c.mu : 0.0);
    return C;
  }

  // ---- Material<dim> --------------------------------------------------------------------------
  bool small_strain() const override { return true; }
  dealii::Tensor<2, dim> stress(unsigned j, const dealii::Tensor<2, dim>& grad_u) const override {
    const dealii::SymmetricTensor<2, dim> eps = dealii::symmetrize(grad_u);
    return stress(cell(j), eps, dealii::trace(eps));
  }
  dealii::Tensor<4, dim> tangent(unsigned j, const dealii::Tensor<2, dim>&) const override {
    return elasticity_tensor(cell(j));
  }
  double energy_density(unsigned j, const dealii::Tensor<2, dim>& grad_u) const override {
    const dealii::SymmetricTensor<2, dim> eps = dealii::symmetrize(grad_u);
    return 0.5 * (stress(cell(j), eps, dealii::trace(eps)) * eps);
  }

 private:
  const std::vector<double>* E_;
  double nu_;
};

}  // namespace vim::fem

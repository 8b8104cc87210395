// The finite-strain material of fem/: a compressible neo-Hookean solid in the form CalculiX and
// Abaqus use (*HYPERELASTIC, NEO HOOKE), per reference volume
//   W(F) = C10 (Ī₁ − 3) + (J − 1)² / D₁,   Ī₁ = J^(−2/3) I₁,  I₁ = F : F,  J = det F,
// with C10 = μ/2 and D₁ = 2/K from the cell's Young's modulus E_j and the model's ν:
// μ = E/(2(1+ν)), K = E/(3(1−2ν)). At F = I its tangent is the linear law's C with λ = K − 2μ/3
// (linear_elastic_material.hpp), so both agree at small strain. 2D is plane strain: F₃₃ = 1, so
// I₁ = F : F + 1 and J = det F of the 2×2 block. docs/finite-strain.md gives the linearisation.
#pragma once

#include <deal.II/base/tensor.h>
#include <deal.II/physics/elasticity/kinematics.h>

#include <cmath>
#include <vector>
#include <vim/fem/material_description.hpp>

#include "linear_elastic_material.hpp"

namespace vim::fem {

template <int dim>
class NeoHookeanMaterial final : public Material<dim> {
 public:
  // A view: the per-cell moduli must outlive it. ν is checked (−1, 0.5).
  NeoHookeanMaterial(const std::vector<double>& youngs_modulus, double poisson_ratio)
      : E_(&youngs_modulus), nu_(poisson_ratio) {
    check_poisson_ratio(nu_);
  }

  // The constants of the energy for a cell of modulus E: C10 = μ/2, D₁ = 2/K.
  struct Constants {
    double c10 = 0.0, d1 = 0.0;
  };
  static Constants constants(double E, double nu) {
    return {MaterialDescription::neo_hookean_c10(E, nu), MaterialDescription::neo_hookean_d1(E, nu)};
  }
  Constants cell(unsigned j) const { return constants((*E_)[j], nu_); }

  bool small_strain() const override { return false; }

  // P = 2 C10 J^(−2/3) (F − I₁/3 F⁻ᵀ) + (2/D₁)(J − 1) J F⁻ᵀ.
  dealii::Tensor<2, dim> stress(unsigned j, const dealii::Tensor<2, dim>& grad_u) const override {
    const Constants c = cell(j);
    const dealii::Tensor<2, dim> F = dealii::Physics::Elasticity::Kinematics::F(grad_u);
    const double J = dealii::determinant(F), a = std::pow(J, -2.0 / 3.0), I1 = first_invariant(F);
    const dealii::Tensor<2, dim> FinvT = dealii::transpose(dealii::invert(F));
    return 2.0 * c.c10 * a * (F - (I1 / 3.0) * FinvT) + (2.0 / c.d1) * (J - 1.0) * J * FinvT;
  }

  // A_iJkL = ∂P_iJ/∂F_kL, with ∂J/∂F = J F⁻ᵀ and ∂(F⁻ᵀ)_iJ/∂F_kL = −F⁻¹_Li F⁻¹_Jk.
  dealii::Tensor<4, dim> tangent(unsigned j, const dealii::Tensor<2, dim>& grad_u) const override {
    const Constants c = cell(j);
    const dealii::Tensor<2, dim> F = dealii::Physics::Elasticity::Kinematics::F(grad_u);
    const double J = dealii::determinant(F), a = std::pow(J, -2.0 / 3.0), I1 = first_invariant(F);
    const dealii::Tensor<2, dim> Finv = dealii::invert(F), FinvT = dealii::transpose(Finv);
    const double g = 2.0 * c.c10 * a, k = 2.0 / c.d1;
    dealii::Tensor<4, dim> A;
    for (unsigned i = 0; i < dim; ++i)
      for (unsigned I = 0; I < dim; ++I)
        for (unsigned m = 0; m < dim; ++m)
          for (unsigned L = 0; L < dim; ++L) {
            const double delta = (i == m && I == L) ? 1.0 : 0.0;
            const double cross = Finv[L][i] * Finv[I][m];  // −∂(F⁻ᵀ)_iI/∂F_mL
            // ∂/∂F_mL of g (F_iI − I₁/3 F⁻ᵀ_iI), with ∂g/∂F = −(2/3) g F⁻ᵀ:
            const double iso =
                g * (delta - (2.0 / 3.0) * FinvT[m][L] * F[i][I] - (2.0 / 3.0) * F[m][L] * FinvT[i][I] +
                     (2.0 / 9.0) * I1 * FinvT[m][L] * FinvT[i][I] + (I1 / 3.0) * cross);
            // ∂/∂F_mL of k (J² − J) F⁻ᵀ_iI:
            const double vol = k * ((2.0 * J - 1.0) * J * FinvT[m][L] * FinvT[i][I] - (J * J - J) * cross);
            A[i][I][m][L] = iso + vol;
          }
    return A;
  }

  double energy_density(unsigned j, const dealii::Tensor<2, dim>& grad_u) const override {
    const Constants c = cell(j);
    const dealii::Tensor<2, dim> F = dealii::Physics::Elasticity::Kinematics::F(grad_u);
    const double J = dealii::determinant(F);
    return c.c10 * (std::pow(J, -2.0 / 3.0) * first_invariant(F) - 3.0) + (J - 1.0) * (J - 1.0) / c.d1;
  }

  // The Cauchy stress σ = P Fᵀ / J (the post-processing's stress).
  dealii::Tensor<2, dim> cauchy_stress(unsigned j, const dealii::Tensor<2, dim>& grad_u) const {
    const dealii::Tensor<2, dim> F = dealii::Physics::Elasticity::Kinematics::F(grad_u);
    return stress(j, grad_u) * dealii::transpose(F) / dealii::determinant(F);
  }
  // σ₃₃ of plane strain (2D): J⁻¹ ∂W/∂F₃₃ F₃₃ at F₃₃ = 1, 2 C10 J^(−2/3)(1 − I₁/3) + (2/D₁)(J − 1) J,
  // over J. 0 in 3D (not used).
  double out_of_plane_stress(unsigned j, const dealii::Tensor<2, dim>& grad_u) const {
    if (dim == 3) return 0.0;
    const Constants c = cell(j);
    const dealii::Tensor<2, dim> F = dealii::Physics::Elasticity::Kinematics::F(grad_u);
    const double J = dealii::determinant(F), I1 = first_invariant(F);
    return (2.0 * c.c10 * std::pow(J, -2.0 / 3.0) * (1.0 - I1 / 3.0) + (2.0 / c.d1) * (J - 1.0) * J) / J;
  }

 private:
  // I₁ = F : F, plus F₃₃² = 1 in plane strain.
  static double first_invariant(const dealii::Tensor<2, dim>& F) {
    return dealii::scalar_product(F, F) + (dim == 2 ? 1.0 : 0.0);
  }
  const std::vector<double>* E_;
  double nu_;
};

}  // namespace vim::fem

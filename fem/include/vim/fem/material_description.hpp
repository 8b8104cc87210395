// The material of the models as the solver decks state it (deal.II-free): what the exports write as
// material cards. The law itself (Lamé parameters, stress, tangent, energy density) is
// fem/src/linear_elastic_material.hpp, the one place of fem/ the element kernels take it from.
#pragma once

#include <ostream>
#include <string>

namespace vim::fem {

// Linear isotropic elasticity with a Young's modulus per cell and one Poisson ratio, plane strain in
// 2D (the law of fem/src/linear_elastic_material.hpp). The exports write their material cards from
// it, so a deck names the law the simulation solves. Numbers are written in the stream's format.
struct MaterialDescription {
  double poisson_ratio = 0.3;
  // The compressible neo-Hookean solid of the finite-strain solve (vim/fem/finite_strain.hpp) instead.
  bool neo_hookean = false;
  // CalculiX/Abaqus: the card of a material of modulus E, "*Elastic\n<E>, <ν>\n", or for neo_hookean
  // "*Hyperelastic, NEO HOOKE\n<C10>, <D1>\n".
  void write_inp_card(std::ostream& out, double youngs_modulus) const;
  // The constants of W = C10 (Ī₁ − 3) + (J − 1)²/D₁ for modulus E and ratio ν: C10 = μ/2 =
  // E/(4(1+ν)) and D₁ = 2/K = 6(1−2ν)/E (the neo-Hookean material of fem/ takes them from here).
  static double neo_hookean_c10(double youngs_modulus, double poisson_ratio);
  static double neo_hookean_d1(double youngs_modulus, double poisson_ratio);
  // FEBio 4: the <material> element (FEBio's "isotropic elastic", St Venant–Kirchhoff, whose
  // small-strain limit is this law; for neo_hookean FEBio's "neo-Hookean", W = μ/2 (I₁ − 3) − μ ln J +
  // λ/2 (ln J)², the closest FEBio material: same μ and λ, another volumetric term), E per element
  // from the element data map `modulus_map`.
  void write_feb_material(std::ostream& out, int id, const std::string& name,
                          const std::string& modulus_map) const;
};

}  // namespace vim::fem

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
  // CalculiX/Abaqus: the card of a material of modulus E, "*Elastic\n<E>, <ν>\n".
  void write_inp_card(std::ostream& out, double youngs_modulus) const;
  // FEBio 4: the <material> element (FEBio's "isotropic elastic", St Venant–Kirchhoff, whose
  // small-strain limit is this law), E per element from the element data map `modulus_map`.
  void write_feb_material(std::ostream& out, int id, const std::string& name,
                          const std::string& modulus_map) const;
};

}  // namespace vim::fem

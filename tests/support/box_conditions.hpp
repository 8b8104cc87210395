// The conditions of the tests' unit-box models [0, 1]^dim: the face x_{dim−1} = 0 held, the face
// x_0 = 0 (x_0 = 1 with far_face) pushed along x_0 by `push` (an inhomogeneous condition, so that
// its condensation into the right-hand side is exercised), and a body force of −0.1 along every axis.
#pragma once

#include <vim/fem/elasticity.hpp>

namespace vim::test {

template <int dim>
void hold_and_push(fem::ElasticModel<dim>& model, bool far_face, double push) {
  const fem::Vec<dim> lo = fem::Vec<dim>::Zero(), hi = fem::Vec<dim>::Ones();
  fem::DirichletBC<dim> fixed;
  fixed.region = fem::box_face_region<dim>(lo, hi, dim - 1, false, 1e-9);
  model.add_dirichlet(fixed);
  fem::DirichletBC<dim> pushed;
  pushed.region = fem::box_face_region<dim>(lo, hi, 0, far_face, 1e-9);
  pushed.components = fem::DirichletBC<dim>::filled(false);
  pushed.components[0] = true;
  pushed.value[0] = push;
  model.add_dirichlet(pushed);
  model.set_body_force(fem::Vec<dim>::Constant(-0.1));
}

}  // namespace vim::test

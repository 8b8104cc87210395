// Embedded point constraints: a point anywhere inside the mesh (e.g. a needle's shaft point) moved
// by a given displacement, through the shape functions of the cell containing it. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <vim/fem/conditions.hpp>

namespace vim::fem {

// u(position) = displacement (selected components), for a point anywhere inside the mesh:
// a linear constraint on the DoFs of the cell containing it, through its shape functions.
// `axes` (orthonormal columns; identity = the model's axes) makes component c the direction
// axes.col(c): axes.col(c)·u(position) = displacement_c. With every component selected the axes
// change nothing but which rows a degenerate set drops: a point on nodes that a DirichletBC holds
// along its own axes leaves those directions to the condition when it uses the same axes.
template <int dim>
struct PointConstraint {
  Vec<dim> position;
  Vec<dim> displacement = Vec<dim>::Zero();
  std::array<bool, dim> components = DirichletBC<dim>::filled(true);
  Eigen::Matrix<double, dim, dim> axes = Eigen::Matrix<double, dim, dim>::Identity();
};

// Point constraints (embedded needle points) that are linear combinations of earlier ones, numerically,
// but ask for other displacements: e.g. shaft points close together along an edge of the mesh.
struct DependentPointConstraints : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace vim::fem

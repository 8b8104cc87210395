// Embedded point constraints: a point anywhere inside the mesh (e.g. a needle's shaft point) moved
// by a given displacement, through the shape functions of the cell containing it; or a weighted
// average of the displacement over sample points (a band of a needle's surface), optionally held
// through a compliance in series (the analytic near field of a needle, docs/needle-model.md).
// deal.II-free.
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <vector>
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
  // Not an aggregate: {position} and {position, displacement} initialise the rest to their defaults
  // (GCC 12 crashes on default member initialisers of the sample lists in nested braced lists, and
  // without them warns of missing initialisers).
  PointConstraint() = default;
  PointConstraint(const Vec<dim>& at, const Vec<dim>& moved_by = Vec<dim>::Zero())
      : position(at), displacement(moved_by) {}
  Vec<dim> position;
  Vec<dim> displacement = Vec<dim>::Zero();
  std::array<bool, dim> components = DirichletBC<dim>::filled(true);
  Eigen::Matrix<double, dim, dim> axes = Eigen::Matrix<double, dim, dim>::Identity();
  // Averaged constraint (empty offsets: the point itself): the held value is
  // ū = Σ_q weights[q]·u(position + offsets[q]), sizes equal, weights ≥ 0 with a positive sum (they are
  // normalised to sum 1). Samples outside the mesh are left out and the remaining weights renormalised;
  // all outside → std::invalid_argument.
  std::vector<Vec<dim>> offsets;
  std::vector<double> weights;
  // Per component c, a compliance κ_c ≥ 0 (displacement per unit force) in series with the row: the
  // force on the body along axes.col(c) is (displacement_c − axes.col(c)·ū)/κ_c; 0 = rigid (exact).
  // A positive κ keeps the rows' Schur complement positive definite: such rows are never dropped.
  Vec<dim> compliance = Vec<dim>::Zero();
};

// Point constraints (embedded needle points) that are linear combinations of earlier ones, numerically,
// but ask for other displacements: e.g. shaft points close together along an edge of the mesh.
struct DependentPointConstraints : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace vim::fem

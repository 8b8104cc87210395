// A Kuhn grid of a box in an oblique world frame, for the tests whose truth must hold for any image
// orientation (the exports, the solver decks): frame box [-1 - a/2, 2 + 3a/2] along axis a, origin
// 10 + 3a, direction a rotation about a generic axis (3D) or by 0.6 rad (2D). No element values.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/common/model.hpp>

namespace vim::test {

template <int dim>
pipeline::MeshModel<dim> oblique_grid(const std::array<int, dim>& nodes) {
  Eigen::Matrix<double, dim, 1> lo, hi;
  for (int a = 0; a < dim; ++a) lo[a] = -1.0 - 0.5 * a, hi[a] = 2.0 + 1.5 * a;
  pipeline::MeshModel<dim> m;
  m.mesh = regular_grid_mesh<dim>(lo, hi, nodes);
  for (int a = 0; a < dim; ++a) m.transform.origin[a] = 10.0 + 3.0 * a;
  if constexpr (dim == 3)
    m.transform.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  else
    m.transform.direction = Eigen::Rotation2Dd(0.6).toRotationMatrix();
  return m;
}

}  // namespace vim::test

// Shared helpers for the mesher primitive tests: random images with anisotropic spacing and a
// non-zero origin, and Kuhn meshes of a box with randomly perturbed nodes (boundary nodes stay on
// their face/edge, corners fixed), so the mesh still covers the box exactly.
#pragma once

#include <vim/image.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/quality.hpp>
#include <vim/simplex_mesh.hpp>

#include <array>
#include <random>

namespace vim::testing {

template <int dim>
Image<dim> random_image(const std::array<long, dim>& size, const std::array<double, dim>& spacing,
                        const std::array<double, dim>& origin, std::mt19937& rng) {
  Image<dim> img(size, spacing, origin);
  std::uniform_real_distribution<float> u(0.5f, 3.0f);
  for (float& v : img.data) v = u(rng);
  return img;
}

// Moves every node by up to `amount` × local cell size (tangentially on the boundary), retrying a
// node's move until all its cells stay positively oriented with max dihedral < 170°.
template <int dim>
SimplexMesh<dim> perturbed_grid_mesh(const Eigen::Matrix<double, dim, 1>& lo, const Eigen::Matrix<double, dim, 1>& hi,
                                     const std::array<int, dim>& n, double amount, std::mt19937& rng) {
  SimplexMesh<dim> mesh = regular_grid_mesh<dim>(lo, hi, n);
  Eigen::Matrix<double, dim, 1> h;
  for (int a = 0; a < dim; ++a) h[a] = (hi[a] - lo[a]) / (n[a] - 1);
  const double tol = 1e-9 * (hi - lo).maxCoeff();
  const auto kind = boundary_kind<dim>(mesh, lo, hi, tol);
  std::vector<std::vector<int>> ring(mesh.n_points());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    for (int v : mesh.cells[c]) ring[v].push_back(static_cast<int>(c));
  std::uniform_real_distribution<double> u(-amount, amount);
  QualityBound bound;
  bound.max_dihedral_deg = 170.0;
  for (std::size_t i = 0; i < mesh.n_points(); ++i) {
    if (kind[i] == dim) continue;
    const auto old = mesh.points[i];
    for (int attempt = 0; attempt < 20; ++attempt) {
      auto p = old;
      for (int a = 0; a < dim; ++a) {
        const bool on_face = std::abs(old[a] - lo[a]) <= tol || std::abs(old[a] - hi[a]) <= tol;
        if (!on_face) p[a] += u(rng) * h[a];
      }
      mesh.points[i] = p;
      bool ok = true;
      for (int c : ring[i]) ok = ok && acceptable<dim>(cell_points(mesh, c), bound);
      if (ok) break;
      mesh.points[i] = old;
    }
  }
  return mesh;
}

}  // namespace vim::testing

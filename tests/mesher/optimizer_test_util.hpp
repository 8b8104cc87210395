// Shared helpers for the VIM optimiser tests (paper §IV, §VI-B): phantom images built in memory
// (Table I sphere, two circles, Fig. 3 diamond) and brute-force references that do not use
// VoxelStatistics: voxel-centre classification and the objective E of Eq. 7 by per-voxel enumeration.
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include <vim/energy.hpp>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

#include "voxel_owner.hpp"

namespace vim::testing {

// Voxel centres (i + 0.5)·(extent/n) of [0, extent]^dim; `inside(p)` → value 2, else 1.
template <int dim, class F>
Image<dim> phantom(long n, double extent, F inside) {
  const double h = extent / static_cast<double>(n);
  std::array<long, dim> size;
  std::array<double, dim> spacing, origin;
  size.fill(n);
  spacing.fill(h);
  origin.fill(0.5 * h);
  Image<dim> img(size, spacing, origin, 1.0f);
  for (std::size_t k = 0; k < img.voxel_count(); ++k)
    if (inside(img.point_of(img.index_of(k)))) img.data[k] = 2.0f;
  return img;
}

// Table I phantom: cube [0,3]^3, sphere of radius 1 at the centre with value 2, background 1.
inline Image<3> sphere_phantom(long n) {
  return phantom<3>(
      n, 3.0, [](const Eigen::Vector3d& p) { return (p - Eigen::Vector3d(1.5, 1.5, 1.5)).norm() <= 1.0; });
}

// Two circles of different sizes in [0,1]^2 (paper Fig. 13(a)).
inline Image<2> two_circle_phantom(long n) {
  return phantom<2>(n, 1.0, [](const Eigen::Vector2d& p) {
    return (p - Eigen::Vector2d(0.32, 0.35)).norm() <= 0.2 ||
           (p - Eigen::Vector2d(0.72, 0.68)).norm() <= 0.12;
  });
}

// For every voxel centre, the index of the first cell (in cell order) whose closed simplex contains
// it by a barycentric test, or -1. Independent of VoxelStatistics' tie rule.
template <int dim>
std::vector<int> brute_force_owner(const Image<dim>& img, const SimplexMesh<dim>& mesh) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  const auto centre = [](const typename Image<dim>::Index& j) {
    Vec p;
    for (int a = 0; a < dim; ++a) p[a] = static_cast<double>(j[a]);
    return p;
  };
  return test::voxel_owner(img, mesh, 0, centre,
                           [](const Vec& b) { return b.minCoeff() >= -1e-12 && b.sum() <= 1.0 + 1e-12; });
}

struct BruteEnergy {
  double eg = 0.0, ed = 0.0;
  double combined(double eg0, double ed0, double lambda) const {
    return (1.0 - lambda) * eg / eg0 + (ed0 > 0.0 ? lambda * ed / ed0 : 0.0);
  }
};

// E_G by Eq. 3 per element (geometric_energy) and E_D = Σ |τ|·var by per-voxel enumeration.
template <int dim>
BruteEnergy brute_force_energy(const Image<dim>& img, const SimplexMesh<dim>& mesh) {
  const auto owner = brute_force_owner(img, mesh);
  std::vector<double> n(mesh.n_cells(), 0.0), s(mesh.n_cells(), 0.0), q(mesh.n_cells(), 0.0);
  for (std::size_t k = 0; k < owner.size(); ++k)
    if (owner[k] >= 0) {
      const double h = img.data[k];
      n[owner[k]] += 1.0;
      s[owner[k]] += h;
      q[owner[k]] += h * h;
    }
  BruteEnergy e;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    e.eg += geometric_energy<dim>(x);
    if (n[c] > 0) {
      const double mean = s[c] / n[c];
      e.ed += std::abs(signed_volume<dim>(x)) * std::max(0.0, q[c] / n[c] - mean * mean);
    }
  }
  return e;
}

}  // namespace vim::testing

// Per-element energies of VIM: the geometric (ODT, interpolation form) energy of paper Eq. 3, its
// density-weighted variant for sizing (§VI-E), the discretisation energy of Eq. 6, and the
// normalised combination E = (1−λ)·E_G/E_G0 + λ·E_D/E_D0 of Eq. 7 / §IV-C.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <vim/simplex_mesh.hpp>

namespace vim {

// E_G(τ) = ∫_τ (I|x|² − |x|²) = |τ| / ((d+1)(d+2)) · Σ_{i<k} |x_i − x_k|², where I|x|² is the linear
// interpolant of |x|² at the vertices. Summed over a mesh this equals Eq. 3 (1-ring form).
template <int dim>
double squared_edge_sum(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  double edges = 0.0;
  for (int i = 0; i <= dim; ++i)
    for (int k = i + 1; k <= dim; ++k) edges += (x[i] - x[k]).squaredNorm();
  return edges;
}

// E_G from a signed volume the caller already has (the optimiser's inner loop): bit-identical to
// geometric_energy(x) when volume == signed_volume(x).
template <int dim>
double geometric_energy_of_volume(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x,
                                  double volume) {
  return std::abs(volume) * squared_edge_sum<dim>(x) / static_cast<double>((dim + 1) * (dim + 2));
}

template <int dim>
double geometric_energy(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  return geometric_energy_of_volume<dim>(x, signed_volume<dim>(x));
}

// Density-weighted E_G: ∫_τ ρ (I|x|² − |x|²) with ρ taken at the centroid (the caller samples it).
template <int dim>
double geometric_energy(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x, double density) {
  return density * geometric_energy<dim>(x);
}

// E_D(τ) = |τ| · var{h(c) : voxel centre c ∈ τ} (Eq. 6 per element).
inline double discretization_energy(double volume, double variance) { return volume * variance; }

// Normalisation of §IV-C: E_G0, E_D0 from the initial mesh, kept fixed. E_D0 == 0 (constant image)
// switches the image term off.
struct EnergyNormalization {
  double eg0 = 1.0, ed0 = 0.0, lambda = 0.0;
  double combined(double eg, double ed) const {
    const double g = (1.0 - lambda) * eg / eg0;
    return ed0 > 0.0 ? g + lambda * ed / ed0 : g;
  }
};

}  // namespace vim

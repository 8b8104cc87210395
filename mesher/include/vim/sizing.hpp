// Mesh sizing of paper §VI-E: an E_G-only initialisation where each element's geometric energy
// (Eq. 3, ODT interpolation form) is weighted by a density image sampled at its centroid, so nodes
// concentrate where the density is high; VIM then starts from the sized mesh.
#pragma once

#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>
#include <vim/vim.hpp>

namespace vim {

// Throws std::invalid_argument if the density image is empty, its data does not match its size, or
// it has a value that is not finite and > 0.
template <int dim>
void validate_density(const Image<dim>& density);

// Runs up to `iterations` sweeps of density-weighted E_G node updates (and swaps if options.swaps)
// with the box constraints and quality bound of `options` (λ is ignored). Returns the sized mesh
// (same nodes, positively oriented). Throws std::invalid_argument if iterations < 0, the density
// image is empty or has a value that is not finite and > 0, or the mesh has an inverted element.
// Stops early on the convergence rule of optimize() (VimOptions::converged). `progress` (if set) is
// called after every sweep with the iteration's v, moves, swaps and the density-weighted E_G (as
// `geometric`; `energy` is it normalised by the initial value, `discretization` is 0).
template <int dim>
SimplexMesh<dim> size_initial_mesh(const Image<dim>& density, SimplexMesh<dim> mesh, int iterations,
                                   const VimOptions& options = {}, const ProgressCallback& progress = {});

// VIM with a sizing field kept throughout (paper §VI-E, "E_G can be modified using a sizing field"):
// size_initial_mesh(density, initial, options.max_iterations, options), then optimize() with each
// element's E_G weighted by the density at its centroid. Where the image is uniform the optimum's
// element size is ∝ density^(−1/(dim+2)). Throws as size_initial_mesh and optimize.
template <int dim>
VimResult<dim> optimize_sized(const Image<dim>& image, const Image<dim>& density, SimplexMesh<dim> initial,
                              const VimOptions& options, const ProgressCallback& progress = {});

}  // namespace vim

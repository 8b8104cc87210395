// Mesh sizing of paper §VI-E: an E_G-only initialisation where each element's geometric energy
// (Eq. 3, ODT interpolation form) is weighted by a density image sampled at its centroid, so nodes
// concentrate where the density is high; VIM then starts from the sized mesh.
#pragma once

#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>
#include <vim/vim.hpp>

namespace vim {

// Runs up to `iterations` sweeps of density-weighted E_G node updates (and swaps if options.swaps)
// with the box constraints and quality bound of `options` (λ is ignored). Returns the sized mesh
// (same nodes, positively oriented). Throws std::invalid_argument if iterations < 0, the density
// image is empty or has a value that is not finite and > 0, or the mesh has an inverted element.
template <int dim>
SimplexMesh<dim> size_initial_mesh(const Image<dim>& density, SimplexMesh<dim> mesh, int iterations,
                                   const VimOptions& options = {});

}  // namespace vim

// Quadratic simplex cells over a linear simplex mesh: one mid-edge node per edge (straight edges,
// the geometry of deal.II's MappingFE(FE_SimplexP(1)) and of the P2 support points). Shared by the
// P2 step VTUs and the solver decks, so that every file numbers the mid-edge nodes the same way.
#pragma once

#include <array>
#include <vector>
#include <vim/simplex_mesh.hpp>

namespace vim::pipeline {

template <int dim>
struct QuadraticCells {
  static constexpr int nodes_per_cell = dim == 3 ? 10 : 6;
  // Edge e joins vertices edges[e][0] < edges[e][1]; its mid-edge node is node n_vertices + e.
  std::vector<std::array<int, 2>> edges;
  // Per cell: its dim+1 vertices as given, then the mid-edge nodes of the edges (0,1), (1,2), (2,0)
  // and in 3D (0,3), (1,3), (2,3): the node order of VTK_QUADRATIC_TETRA / VTK_QUADRATIC_TRIANGLE,
  // CalculiX/Abaqus C3D10 / CPE6 and FEBio tet10 / tri6 (Gmsh's 10-node tetrahedron swaps the last two).
  std::vector<std::array<long, nodes_per_cell>> cells;
};

// Local vertex pairs of the edges in the order above.
template <int dim>
const std::vector<std::array<int, 2>>& quadratic_edge_order();

// Edges numbered in order of first appearance over the cells (deterministic).
template <int dim>
QuadraticCells<dim> quadratic_cells(const std::vector<std::array<int, dim + 1>>& cells,
                                    std::size_t n_vertices);

}  // namespace vim::pipeline

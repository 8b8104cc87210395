// The part of a simplex model's mesh that one rank of a fully distributed solve builds
// (distributed_system.hpp): every rank partitions the input cells alike (METIS on the cells' face
// graph, as parallel::shared::Triangulation does), then describes only its own cells and the ghost
// cells around them, each a coarse cell of its own with its input index as the coarse-cell id; no
// rank builds the serial triangulation. parallel::fullydistributed::Triangulation::create_triangulation then
// sorts and builds these cells only, not the whole mesh (docs/mpi.md).
#include <deal.II/base/mpi.h>
#include <deal.II/grid/cell_id.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vim/facets.hpp>

#include "distributed_system.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

// The cells' face graph: each cell, and the pairs of cells sharing a facet (dim vertices), both ways.
template <int dim>
DynamicSparsityPattern face_graph(std::size_t n_vertices,
                                  const std::vector<std::array<int, dim + 1>>& cells) {
  DynamicSparsityPattern graph(cells.size(), cells.size());
  for (unsigned c = 0; c < cells.size(); ++c) graph.add(c, c);
  const FacetIncidence<dim> facets = match_facets<dim>(n_vertices, cells);
  for (std::size_t g = 0; g < facets.n_facets(); ++g)
    if (facets.count(g) == 2) {
      const std::size_t a = facets.use(g, 0).cell(), b = facets.use(g, 1).cell();
      graph.add(a, b), graph.add(b, a);
    }
  return graph;
}

}  // namespace

template <int dim>
std::vector<unsigned> partition_cells(const std::vector<Vec<dim>>& vertices,
                                      const std::vector<std::array<int, dim + 1>>& cells, unsigned n_ranks) {
  const auto n_cells = static_cast<unsigned>(cells.size());
  if (n_cells < n_ranks)
    throw std::invalid_argument("distributed solve: the mesh has " + std::to_string(n_cells) +
                                " cells, fewer than the " + std::to_string(n_ranks) +
                                " MPI ranks; run on at most as many ranks as cells");
  std::vector<unsigned> owner(n_cells, 0);
  if (n_ranks == 1) return owner;
  SparsityPattern graph;
  graph.copy_from(face_graph<dim>(vertices.size(), cells));
  SparsityTools::partition(graph, n_ranks, owner, SparsityTools::Partitioner::metis);
  std::vector<unsigned> per_rank(n_ranks, 0);
  for (const unsigned r : owner) ++per_rank.at(r);
  for (const unsigned n : per_rank)
    if (n == 0) {
      for (unsigned c = 0; c < n_cells; ++c)
        owner[c] = static_cast<unsigned>(std::uint64_t(c) * n_ranks / n_cells);
      break;
    }
  return owner;
}

template <int dim>
SimplexPart<dim> simplex_part(const std::vector<Vec<dim>>& vertices,
                              const std::vector<std::array<int, dim + 1>>& cells, MPI_Comm comm) {
  const unsigned rank = Utilities::MPI::this_mpi_process(comm);
  const std::vector<unsigned> owner =
      partition_cells<dim>(vertices, cells, Utilities::MPI::n_mpi_processes(comm));
  // The rank's cells and every cell that shares a vertex with one of them (its ghosts).
  std::vector<char> near(vertices.size(), 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
    if (owner[c] == rank)
      for (const int v : cells[c]) near[static_cast<std::size_t>(v)] = 1;
  std::vector<char> relevant(cells.size(), 0), used(vertices.size(), 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (const int v : cells[c])
      if (near[static_cast<std::size_t>(v)]) {
        relevant[c] = 1;
        for (const int w : cells[c]) used[static_cast<std::size_t>(w)] = 1;
        break;
      }
  // Local vertices in the serial order, so that edges keep their orientation.
  SimplexPart<dim> part;
  TriangulationDescription::Description<dim, dim>& d = part.description;
  std::vector<unsigned> local_vertex(vertices.size(), numbers::invalid_unsigned_int);
  for (unsigned v = 0; v < vertices.size(); ++v)
    if (used[v]) {
      local_vertex[v] = static_cast<unsigned>(part.serial_vertex.size());
      part.serial_vertex.push_back(v);
      d.coarse_cell_vertices.push_back(to_point<dim>(vertices[v]));
    }
  d.comm = comm;
  d.settings = TriangulationDescription::Settings::default_setting;
  d.smoothing = Triangulation<dim>::none;
  d.cell_infos.resize(1);
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (!relevant[c]) continue;
    dealii::CellData<dim> coarse(dim + 1);
    for (int k = 0; k <= dim; ++k) coarse.vertices[k] = local_vertex[static_cast<std::size_t>(cells[c][k])];
    coarse.material_id = static_cast<types::material_id>(c);
    d.coarse_cells.push_back(coarse);
    d.coarse_cell_index_to_coarse_cell_id.push_back(c);
    // every face keeps boundary id 0, the default (the model's loads select faces by region)
    TriangulationDescription::CellData<dim> info;
    info.id = CellId(c, std::vector<std::uint8_t>()).template to_binary<dim>();
    info.subdomain_id = owner[c];
    info.level_subdomain_id = numbers::invalid_subdomain_id;
    info.manifold_id = numbers::flat_manifold_id;
    info.manifold_line_ids.fill(numbers::flat_manifold_id);
    info.manifold_quad_ids.fill(numbers::flat_manifold_id);
    d.cell_infos[0].push_back(info);
  }
  return part;
}

template std::vector<unsigned> partition_cells<2>(const std::vector<Vec<2>>&,
                                                  const std::vector<std::array<int, 3>>&, unsigned);
template std::vector<unsigned> partition_cells<3>(const std::vector<Vec<3>>&,
                                                  const std::vector<std::array<int, 4>>&, unsigned);
template SimplexPart<2> simplex_part<2>(const std::vector<Vec<2>>&, const std::vector<std::array<int, 3>>&,
                                        MPI_Comm);
template SimplexPart<3> simplex_part<3>(const std::vector<Vec<3>>&, const std::vector<std::array<int, 4>>&,
                                        MPI_Comm);

}  // namespace vim::fem

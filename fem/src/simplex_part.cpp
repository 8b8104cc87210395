// The part of a simplex model's mesh that one rank of a fully distributed solve builds
// (distributed_system.hpp): every rank partitions the serial triangulation it holds alike (METIS on
// the cells' face graph, as parallel::shared::Triangulation does), then describes only its own cells
// and the ghost cells around them, each a coarse cell of its own with its serial index as the
// coarse-cell id. parallel::fullydistributed::Triangulation::create_triangulation then sorts and
// builds these cells only, not the whole mesh (docs/mpi.md).
#include <deal.II/base/mpi.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>

#include <stdexcept>
#include <string>

#include "distributed_system.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

// Owning rank per active cell (index: active_cell_index), the same on every rank: METIS on the face
// graph of the cells; blocks of consecutive cells when METIS would leave a rank without cells.
template <int dim>
std::vector<unsigned> partition_cells(const Triangulation<dim>& serial, unsigned n_ranks) {
  const unsigned n_cells = serial.n_active_cells();
  if (n_cells < n_ranks)
    throw std::invalid_argument("distributed solve: the mesh has " + std::to_string(n_cells) +
                                " cells, fewer than the " + std::to_string(n_ranks) +
                                " MPI ranks; run on at most as many ranks as cells");
  std::vector<unsigned> owner(n_cells, 0);
  if (n_ranks == 1) return owner;
  DynamicSparsityPattern faces;
  GridTools::get_face_connectivity_of_cells(serial, faces);
  SparsityPattern graph;
  graph.copy_from(faces);
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

}  // namespace

template <int dim>
SimplexPart<dim> simplex_part(const Triangulation<dim>& serial, MPI_Comm comm) {
  const unsigned rank = Utilities::MPI::this_mpi_process(comm);
  const std::vector<unsigned> owner = partition_cells(serial, Utilities::MPI::n_mpi_processes(comm));
  // The rank's cells and every cell that shares a vertex with one of them (its ghosts).
  std::vector<char> near(serial.n_vertices(), 0);
  for (const auto& cell : serial.active_cell_iterators())
    if (owner[cell->active_cell_index()] == rank)
      for (const unsigned v : cell->vertex_indices()) near[cell->vertex_index(v)] = 1;
  std::vector<char> relevant(serial.n_active_cells(), 0), used(serial.n_vertices(), 0);
  for (const auto& cell : serial.active_cell_iterators())
    for (const unsigned v : cell->vertex_indices())
      if (near[cell->vertex_index(v)]) {
        relevant[cell->active_cell_index()] = 1;
        for (const unsigned w : cell->vertex_indices()) used[cell->vertex_index(w)] = 1;
        break;
      }
  // Local vertices in the serial order, so that edges keep their orientation.
  SimplexPart<dim> part;
  TriangulationDescription::Description<dim, dim>& d = part.description;
  std::vector<unsigned> local_vertex(serial.n_vertices(), numbers::invalid_unsigned_int);
  for (unsigned v = 0; v < serial.n_vertices(); ++v)
    if (used[v]) {
      local_vertex[v] = static_cast<unsigned>(part.serial_vertex.size());
      part.serial_vertex.push_back(v);
      d.coarse_cell_vertices.push_back(serial.get_vertices()[v]);
    }
  d.comm = comm;
  d.settings = TriangulationDescription::Settings::default_setting;
  d.smoothing = Triangulation<dim>::none;
  d.cell_infos.resize(1);
  for (const auto& cell : serial.active_cell_iterators()) {
    if (!relevant[cell->active_cell_index()]) continue;
    dealii::CellData<dim> coarse(cell->n_vertices());
    for (const unsigned v : cell->vertex_indices()) coarse.vertices[v] = local_vertex[cell->vertex_index(v)];
    coarse.material_id = cell->material_id();
    d.coarse_cells.push_back(coarse);
    d.coarse_cell_index_to_coarse_cell_id.push_back(cell->id().get_coarse_cell_id());
    TriangulationDescription::CellData<dim> info;
    info.id = cell->id().template to_binary<dim>();
    info.subdomain_id = owner[cell->active_cell_index()];
    info.level_subdomain_id = numbers::invalid_subdomain_id;
    info.manifold_id = numbers::flat_manifold_id;
    info.manifold_line_ids.fill(numbers::flat_manifold_id);
    info.manifold_quad_ids.fill(numbers::flat_manifold_id);
    for (const unsigned f : cell->face_indices())
      if (cell->face(f)->at_boundary()) info.boundary_ids.emplace_back(f, cell->face(f)->boundary_id());
    d.cell_infos[0].push_back(info);
  }
  return part;
}

template SimplexPart<2> simplex_part<2>(const Triangulation<2>&, MPI_Comm);
template SimplexPart<3> simplex_part<3>(const Triangulation<3>&, MPI_Comm);

}  // namespace vim::fem

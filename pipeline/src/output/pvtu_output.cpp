// Parallel VTU output (vtk_output.hpp): a piece of a grid (some of its cells, with the points they use
// and their fields) for a .vtu of its own, and the .pvtu that names the pieces (VTK's
// PUnstructuredGrid XML, read by ParaView and vtkXMLPUnstructuredGridReader as one grid).
#include <stdexcept>
#include <unordered_map>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "output/xml_text.hpp"

namespace vim::pipeline {

namespace fs = std::filesystem;

UnstructuredGrid grid_cells(const UnstructuredGrid& grid, const std::vector<std::size_t>& cells,
                            std::vector<std::size_t>* points_used) {
  const std::size_t nc = grid.n_cells(), npc = static_cast<std::size_t>(grid.nodes_per_cell);
  UnstructuredGrid piece;
  piece.vtk_cell_type = grid.vtk_cell_type;
  piece.nodes_per_cell = grid.nodes_per_cell;
  piece.connectivity.reserve(cells.size() * npc);
  std::unordered_map<long, long> local;  // grid point -> piece point
  std::vector<std::size_t> used;
  for (const std::size_t c : cells) {
    if (c >= nc)
      throw std::invalid_argument("grid_cells: cell " + std::to_string(c) + " of a grid of " +
                                  std::to_string(nc) + " cells");
    for (std::size_t k = c * npc; k < (c + 1) * npc; ++k) {
      const long v = grid.connectivity[k];
      const auto [at, added] = local.emplace(v, static_cast<long>(used.size()));
      if (added) used.push_back(static_cast<std::size_t>(v));
      piece.connectivity.push_back(at->second);
    }
  }
  piece.points.reserve(used.size());
  for (const std::size_t v : used) piece.points.push_back(grid.points.at(v));
  const auto pick = [](const Field& f, const std::vector<std::size_t>& rows) {
    Field g{f.components, {}};
    const auto n = static_cast<std::size_t>(f.components);
    g.values.reserve(rows.size() * n);
    for (const std::size_t i : rows)
      g.values.insert(g.values.end(), f.values.begin() + i * n, f.values.begin() + (i + 1) * n);
    return g;
  };
  for (const auto& [name, f] : grid.point_data) piece.point_data[name] = pick(f, used);
  for (const auto& [name, f] : grid.cell_data) piece.cell_data[name] = pick(f, cells);
  if (points_used) *points_used = std::move(used);
  return piece;
}

std::string pvtu_piece(const std::string& relative, int r) {
  const fs::path rel(relative);
  return (rel.parent_path() / (rel.stem().string() + "_" + std::to_string(r) + ".vtu")).string();
}

void write_pvtu(const fs::path& path, int pieces, const UnstructuredGrid& fields) {
  // Arrays as write_vtu writes them: Float64, 2-component vectors padded to 3.
  const auto arrays = [](std::ostream& out, const FieldMap& map) {
    for (const auto& [name, f] : map)
      out << "      <PDataArray type=\"Float64\" Name=\"" << xml_escape(name) << "\" NumberOfComponents=\""
          << (f.components == 2 ? 3 : f.components) << "\"/>\n";
  };
  const std::string stem = path.stem().string();
  write_text_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n"
        << "  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>\n";
    arrays(out, fields.point_data);
    out << "    </PPointData>\n    <PCellData>\n";
    arrays(out, fields.cell_data);
    out << "    </PCellData>\n    <PPoints>\n      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n"
        << "    </PPoints>\n";
    for (int r = 0; r < pieces; ++r)
      out << "    <Piece Source=\"" << xml_escape(stem + "_" + std::to_string(r) + ".vtu") << "\"/>\n";
    out << "  </PUnstructuredGrid>\n</VTKFile>\n";
  });
}

}  // namespace vim::pipeline

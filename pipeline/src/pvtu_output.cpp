// Parallel VTU output (vtk_output.hpp): a grid cut into pieces by blocks of cells, each piece a .vtu,
// and the .pvtu that names them (VTK's PUnstructuredGrid XML, read by ParaView and
// vtkXMLPUnstructuredGridReader as one grid).
#include <stdexcept>
#include <unordered_map>
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/vtk_output.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

UnstructuredGrid grid_piece(const UnstructuredGrid& grid, int r, int pieces) {
  if (pieces < 1 || r < 0 || r >= pieces)
    throw std::invalid_argument("grid_piece: piece " + std::to_string(r) + " of " + std::to_string(pieces));
  const std::size_t nc = grid.n_cells(), npc = static_cast<std::size_t>(grid.nodes_per_cell);
  const std::size_t first = nc * static_cast<std::size_t>(r) / static_cast<std::size_t>(pieces);
  const std::size_t last = nc * static_cast<std::size_t>(r + 1) / static_cast<std::size_t>(pieces);
  UnstructuredGrid piece;
  piece.vtk_cell_type = grid.vtk_cell_type;
  piece.nodes_per_cell = grid.nodes_per_cell;
  std::unordered_map<long, long> local;  // grid point -> piece point
  std::vector<std::size_t> used;
  for (std::size_t k = first * npc; k < last * npc; ++k) {
    const long v = grid.connectivity[k];
    const auto [at, added] = local.emplace(v, static_cast<long>(used.size()));
    if (added) used.push_back(static_cast<std::size_t>(v));
    piece.connectivity.push_back(at->second);
  }
  for (const std::size_t v : used) piece.points.push_back(grid.points.at(v));
  for (const auto& [name, f] : grid.point_data) {
    Field& g = piece.point_data[name];
    g.components = f.components;
    const auto n = static_cast<std::size_t>(f.components);
    for (const std::size_t v : used)
      g.values.insert(g.values.end(), f.values.begin() + v * n, f.values.begin() + (v + 1) * n);
  }
  for (const auto& [name, f] : grid.cell_data) {
    const auto n = static_cast<std::size_t>(f.components);
    piece.cell_data[name] =
        Field{f.components, std::vector<double>(f.values.begin() + first * n, f.values.begin() + last * n)};
  }
  return piece;
}

void write_pvtu(const std::function<fs::path(const std::string&)>& file, const std::string& relative,
                const UnstructuredGrid& grid, int pieces) {
  const fs::path rel(relative);
  const std::string stem = rel.stem().string();
  const fs::path folder = rel.parent_path();
  std::vector<std::string> sources;
  for (int r = 0; r < pieces; ++r) {
    sources.push_back(stem + "_" + std::to_string(r) + ".vtu");
    write_vtu(file((folder / sources.back()).string()), grid_piece(grid, r, pieces));
  }
  // Arrays as write_vtu writes them: Float64, 2-component vectors padded to 3.
  const auto arrays = [](std::ostream& out, const FieldMap& fields) {
    for (const auto& [name, f] : fields)
      out << "      <PDataArray type=\"Float64\" Name=\"" << name << "\" NumberOfComponents=\""
          << (f.components == 2 ? 3 : f.components) << "\"/>\n";
  };
  write_text_atomically(file(relative), [&](std::ostream& out) {
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n"
        << "  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>\n";
    arrays(out, grid.point_data);
    out << "    </PPointData>\n    <PCellData>\n";
    arrays(out, grid.cell_data);
    out << "    </PCellData>\n    <PPoints>\n      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n"
        << "    </PPoints>\n";
    for (const auto& s : sources) out << "    <Piece Source=\"" << s << "\"/>\n";
    out << "  </PUnstructuredGrid>\n</VTKFile>\n";
  });
}

}  // namespace vim::pipeline

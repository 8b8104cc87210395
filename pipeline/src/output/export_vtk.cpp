// Legacy VTK export (mesh.vtk) for deal.II's GridIn::read_vtk: version 3.0 header, ASCII,
// UNSTRUCTURED_GRID, classic CELLS layout, cell data `SCALARS MaterialID int` (read as material_id: the
// material bin, or with --labels the element's label) followed by the per-element modulus (STACK.md "Mesh
// files for deal.II").
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/exports.hpp>

namespace vim::pipeline {

template <int dim>
void write_vtk_legacy(const std::filesystem::path& path, const SimplexMesh<dim>& world,
                      const MaterialBins& bins) {
  const std::size_t n = world.n_points(), m = world.n_cells();
  if (bins.element_material.size() != m) throw std::invalid_argument("material bins do not match the mesh");
  write_text_atomically(path, [&](std::ostream& out) {
    out << "# vtk DataFile Version 3.0\n"
        << "vim-pipeline VIM mesh, world coordinates\n"
        << "ASCII\n"
        << "DATASET UNSTRUCTURED_GRID\n"
        << "POINTS " << n << " double\n";
    for (const auto& p : world.points)
      out << p[0] << ' ' << p[1] << ' ' << (dim == 3 ? p[dim - 1] : 0.0) << '\n';
    out << "\nCELLS " << m << ' ' << m * (dim + 2) << '\n';
    for (const auto& c : world.cells) {
      out << dim + 1;
      for (int v : c) out << ' ' << v;
      out << '\n';
    }
    out << "\nCELL_TYPES " << m << '\n';
    const int vtk_type = dim == 3 ? 10 : 5;  // VTK_TETRA, VTK_TRIANGLE
    for (std::size_t c = 0; c < m; ++c) out << vtk_type << '\n';
    out << "\nCELL_DATA " << m << '\n' << "SCALARS MaterialID int 1\nLOOKUP_TABLE default\n";
    for (int k : bins.element_material) out << bins.material_id[static_cast<std::size_t>(k - 1)] << '\n';
    out << "\nSCALARS youngs_modulus double 1\nLOOKUP_TABLE default\n";
    for (double e : bins.element_modulus) out << e << '\n';
  });
}

template void write_vtk_legacy<2>(const std::filesystem::path&, const SimplexMesh<2>&, const MaterialBins&);
template void write_vtk_legacy<3>(const std::filesystem::path&, const SimplexMesh<3>&, const MaterialBins&);

}  // namespace vim::pipeline

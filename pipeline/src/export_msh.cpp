// Gmsh 4.1 ASCII export (mesh.msh) readable by Gmsh and deal.II's GridIn::read_msh: one
// volume (3D) / surface (2D) entity per material bin carrying one physical group with the same tag,
// so deal.II's material_id equals the MaterialID of mesh.vtk. All nodes sit in the first entity
// block (parametric 0); element tags are the cell indices + 1.
#include <algorithm>
#include <cmath>
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/exports.hpp>

namespace vim::pipeline {

template <int dim>
void write_msh(const std::filesystem::path& path, const SimplexMesh<dim>& world, const MaterialBins& bins) {
  const std::size_t n = world.n_points(), m = world.n_cells(), nb = bins.n_bins();
  if (bins.element_material.size() != m) throw std::invalid_argument("material bins do not match the mesh");
  if (m == 0) throw std::invalid_argument("cannot write an empty mesh to " + path.string());

  // Cells and bounding boxes per bin (entity).
  std::vector<std::vector<std::size_t>> members(nb);
  std::vector<Eigen::Vector3d> lo(nb, Eigen::Vector3d::Constant(INFINITY)),
      hi(nb, Eigen::Vector3d::Constant(-INFINITY));
  for (std::size_t c = 0; c < m; ++c) {
    const int k = bins.element_material[c] - 1;
    members[k].push_back(c);
    for (int v : world.cells[c])
      for (int a = 0; a < dim; ++a) {
        lo[k][a] = std::min(lo[k][a], world.points[v][a]);
        hi[k][a] = std::max(hi[k][a], world.points[v][a]);
      }
  }
  for (std::size_t k = 0; k < nb; ++k)
    if (dim == 2) lo[k][2] = hi[k][2] = 0.0;

  write_text_atomically(path, [&](std::ostream& out) {
    out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
    out << "$PhysicalNames\n" << nb << '\n';
    for (std::size_t k = 0; k < nb; ++k) out << dim << ' ' << k + 1 << " \"material_" << k + 1 << "\"\n";
    out << "$EndPhysicalNames\n";
    // numPoints numCurves numSurfaces numVolumes; then per entity:
    // tag minX minY minZ maxX maxY maxZ numPhysicalTags physicalTag numBoundingEntities
    out << "$Entities\n"
        << "0 0 " << (dim == 2 ? nb : 0) << ' ' << (dim == 3 ? nb : 0) << '\n';
    for (std::size_t k = 0; k < nb; ++k)
      out << k + 1 << ' ' << lo[k][0] << ' ' << lo[k][1] << ' ' << lo[k][2] << ' ' << hi[k][0] << ' '
          << hi[k][1] << ' ' << hi[k][2] << " 1 " << k + 1 << " 0\n";
    out << "$EndEntities\n";
    // numEntityBlocks numNodes minNodeTag maxNodeTag / entityDim entityTag parametric numNodesInBlock
    out << "$Nodes\n1 " << n << " 1 " << n << '\n' << dim << " 1 0 " << n << '\n';
    for (std::size_t i = 0; i < n; ++i) out << i + 1 << '\n';
    for (const auto& p : world.points)
      out << p[0] << ' ' << p[1] << ' ' << (dim == 3 ? p[dim - 1] : 0.0) << '\n';
    out << "$EndNodes\n";
    // numEntityBlocks numElements minElementTag maxElementTag / entityDim entityTag elementType
    // numElementsInBlock
    const int gmsh_type = dim == 3 ? 4 : 2;  // 4-node tetrahedron, 3-node triangle
    out << "$Elements\n" << nb << ' ' << m << " 1 " << m << '\n';
    for (std::size_t k = 0; k < nb; ++k) {
      out << dim << ' ' << k + 1 << ' ' << gmsh_type << ' ' << members[k].size() << '\n';
      for (std::size_t c : members[k]) {
        out << c + 1;
        for (int v : world.cells[c]) out << ' ' << v + 1;
        out << '\n';
      }
    }
    out << "$EndElements\n";
  });
}

template void write_msh<2>(const std::filesystem::path&, const SimplexMesh<2>&, const MaterialBins&);
template void write_msh<3>(const std::filesystem::path&, const SimplexMesh<3>&, const MaterialBins&);

}  // namespace vim::pipeline

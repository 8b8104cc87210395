// Gmsh 4.1 ASCII export (mesh.msh) readable by Gmsh and deal.II's GridIn::read_msh (linear meshes):
// physical groups for the materials (one volume entity per material bin in 3D, surface in 2D, physical
// tag = bin id, named material_ID, so deal.II's material_id equals the MaterialID of mesh.vtk; with
// --labels one per label, named by the label's name, tag = its rank among the labels), for the image box
// faces and every scenario region's boundary faces (one surface entity each in 3D, curve in 2D), and for
// every scenario region's nodes (one point entity each, holding point elements). Degree 2: 10-node tetrahedra
// / 6-node triangles and quadratic faces. All nodes sit in the first entity block.
#include <algorithm>
#include <cmath>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/exports.hpp>

namespace vim::pipeline {

namespace {

struct Group {
  int dim = 0;
  std::string name;
  std::vector<std::vector<long>> elements;  // node lists (0-based), in Gmsh's node order
  int type = 0;                             // Gmsh element type
};

template <int dim>
std::vector<Group> msh_groups(const SolverDeck<dim>& deck, const MaterialBins& bins) {
  const bool quadratic = deck.degree == 2;
  std::vector<Group> groups(bins.n_bins());
  for (std::size_t k = 0; k < bins.n_bins(); ++k) {
    groups[k].dim = dim;
    groups[k].name = bins.name[k];
    groups[k].type = dim == 3 ? (quadratic ? 11 : 4) : (quadratic ? 9 : 2);
  }
  for (std::size_t c = 0; c < deck.cells.size(); ++c) {
    std::vector<long> n = deck.cells[c];
    if (dim == 3 && quadratic) std::swap(n[8], n[9]);  // Gmsh: edges (3,0), (3,2), (3,1) last
    groups[bins.element_material[c] - 1].elements.push_back(std::move(n));
  }
  const int face_type = dim == 3 ? (quadratic ? 9 : 2) : (quadratic ? 8 : 1);
  auto add_faces = [&](const typename SolverDeck<dim>::Set& s) {
    if (s.faces.empty()) return;
    Group g{dim - 1, s.name, {}, face_type};
    for (const auto& f : s.faces) g.elements.push_back(deck.face_nodes(f));
    groups.push_back(std::move(g));
  };
  for (const auto& s : deck.box_faces) add_faces(s);
  for (const auto& s : deck.regions) add_faces(s);
  for (const auto& s : deck.regions) {
    Group g{0, s.name + "_nodes", {}, 15};
    for (long n : s.nodes) g.elements.push_back({n});
    if (!g.elements.empty()) groups.push_back(std::move(g));
  }
  return groups;
}

}  // namespace

template <int dim>
void write_msh(const std::filesystem::path& path, const SolverDeck<dim>& deck, const MaterialBins& bins) {
  const std::size_t n = deck.nodes.size();
  if (bins.element_material.size() != deck.cells.size())
    throw std::invalid_argument("material bins do not match the mesh");
  if (deck.cells.empty()) throw std::invalid_argument("cannot write an empty mesh to " + path.string());
  const std::vector<Group> groups = msh_groups(deck, bins);
  std::array<std::size_t, 4> per_dim{};
  std::size_t n_elements = 0;
  for (const auto& g : groups) ++per_dim[g.dim], n_elements += g.elements.size();

  write_text_atomically(path, [&](std::ostream& out) {
    out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
    out << "$PhysicalNames\n" << groups.size() << '\n';
    for (std::size_t k = 0; k < groups.size(); ++k)
      out << groups[k].dim << ' ' << k + 1 << " \"" << groups[k].name << "\"\n";
    out << "$EndPhysicalNames\n";
    // Entity tag = physical tag = group index + 1 (unique within each dimension).
    // Points: tag X Y Z numPhysicalTags tag; others: tag box(6) numPhysicalTags tag numBounding 0.
    out << "$Entities\n" << per_dim[0] << ' ' << per_dim[1] << ' ' << per_dim[2] << ' ' << per_dim[3] << '\n';
    for (int d = 0; d <= 3; ++d)
      for (std::size_t k = 0; k < groups.size(); ++k) {
        if (groups[k].dim != d) continue;
        Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
        for (const auto& e : groups[k].elements)
          for (long v : e)
            for (int a = 0; a < dim; ++a)
              lo[a] = std::min(lo[a], deck.nodes[v][a]), hi[a] = std::max(hi[a], deck.nodes[v][a]);
        if (dim == 2) lo[2] = hi[2] = 0.0;
        out << k + 1 << ' ' << lo[0] << ' ' << lo[1] << ' ' << lo[2];
        if (d > 0) out << ' ' << hi[0] << ' ' << hi[1] << ' ' << hi[2];
        out << " 1 " << k + 1 << (d > 0 ? " 0\n" : "\n");
      }
    out << "$EndEntities\n";
    // numEntityBlocks numNodes minNodeTag maxNodeTag / entityDim entityTag parametric numNodesInBlock
    out << "$Nodes\n1 " << n << " 1 " << n << '\n' << dim << " 1 0 " << n << '\n';
    for (std::size_t i = 0; i < n; ++i) out << i + 1 << '\n';
    for (const auto& p : deck.nodes)
      out << p[0] << ' ' << p[1] << ' ' << (dim == 3 ? p[dim - 1] : 0.0) << '\n';
    out << "$EndNodes\n";
    // numEntityBlocks numElements minElementTag maxElementTag / entityDim entityTag elementType
    // numElementsInBlock
    out << "$Elements\n" << groups.size() << ' ' << n_elements << " 1 " << n_elements << '\n';
    std::size_t tag = 0;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      const Group& g = groups[k];
      out << g.dim << ' ' << k + 1 << ' ' << g.type << ' ' << g.elements.size() << '\n';
      for (const auto& e : g.elements) {
        out << ++tag;
        for (long v : e) out << ' ' << v + 1;
        out << '\n';
      }
    }
    out << "$EndElements\n";
  });
}

template void write_msh<2>(const std::filesystem::path&, const SolverDeck<2>&, const MaterialBins&);
template void write_msh<3>(const std::filesystem::path&, const SolverDeck<3>&, const MaterialBins&);

}  // namespace vim::pipeline

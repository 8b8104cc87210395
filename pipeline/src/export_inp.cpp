// Abaqus input export (mesh.inp): *Node, one *Element block per material bin (ELSET MAT_<id>,
// C3D4 linear tetrahedra, CPE3 plane-strain triangles in 2D, as the simulation), and per bin a *Material with
// *Elastic (E = the bin's mean modulus, ν) and a *Solid Section tying the set to it. Node and element numbers
// are the 0-based mesh indices + 1.
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/exports.hpp>

namespace vim::pipeline {

template <int dim>
void write_inp(const std::filesystem::path& path, const SimplexMesh<dim>& world, const MaterialBins& bins,
               double poisson_ratio) {
  const std::size_t m = world.n_cells(), nb = bins.n_bins();
  if (bins.element_material.size() != m) throw std::invalid_argument("material bins do not match the mesh");
  std::vector<std::vector<std::size_t>> members(nb);
  for (std::size_t c = 0; c < m; ++c) members[bins.element_material[c] - 1].push_back(c);
  const char* type = dim == 3 ? "C3D4" : "CPE3";  // plane strain, as fem/
  write_text_atomically(path, [&](std::ostream& out) {
    out << "*Heading\nvim-pipeline VIM mesh, world coordinates; " << nb << " material bins\n";
    out << "*Node\n";
    for (std::size_t i = 0; i < world.n_points(); ++i) {
      out << i + 1;
      for (int a = 0; a < dim; ++a) out << ", " << world.points[i][a];
      out << '\n';
    }
    for (std::size_t k = 0; k < nb; ++k) {
      if (members[k].empty()) continue;
      out << "*Element, TYPE=" << type << ", ELSET=MAT_" << k + 1 << '\n';
      for (std::size_t c : members[k]) {
        out << c + 1;
        for (int v : world.cells[c]) out << ", " << v + 1;
        out << '\n';
      }
    }
    for (std::size_t k = 0; k < nb; ++k) {
      out << "*Solid Section, ELSET=MAT_" << k + 1 << ", MATERIAL=MATERIAL_" << k + 1 << '\n'
          << (dim == 2 ? "1.0\n" : ",\n");  // 2D: unit thickness
    }
    for (std::size_t k = 0; k < nb; ++k)
      out << "*Material, NAME=MATERIAL_" << k + 1 << "\n*Elastic\n"
          << bins.modulus[k] << ", " << poisson_ratio << '\n';
  });
}

template void write_inp<2>(const std::filesystem::path&, const SimplexMesh<2>&, const MaterialBins&, double);
template void write_inp<3>(const std::filesystem::path&, const SimplexMesh<3>&, const MaterialBins&, double);

}  // namespace vim::pipeline

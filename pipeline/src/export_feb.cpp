// FEBio export (mesh.feb), febio_spec 3.0 as described in the FEBio 3.4 user manual (§3.6 Mesh,
// §3.7 MeshDomains, §3.8.2 ElementData maps, Appendix A mapped parameters), which FEBio 3 and 4 read:
// one isotropic-elastic material whose E is the per-element map `E_map` (the element's own modulus,
// not the bin), linear tetrahedra (tet4), and a one-step static Control section so FEBio runs it
// once boundary conditions are added.
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/exports.hpp>

namespace vim::pipeline {

void write_feb(const std::filesystem::path& path, const SimplexMesh<3>& world, const MaterialBins& bins,
               double poisson_ratio) {
  const std::size_t m = world.n_cells();
  if (bins.element_modulus.size() != m) throw std::invalid_argument("element moduli do not match the mesh");
  write_text_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n"
        << "<!-- vim-pipeline VIM mesh, world coordinates; E per element in MeshData/E_map -->\n"
        << "<febio_spec version=\"3.0\">\n"
        << "  <Module type=\"solid\"/>\n"
        << "  <Control>\n"
        << "    <analysis>STATIC</analysis>\n"
        << "    <time_steps>1</time_steps>\n"
        << "    <step_size>1</step_size>\n"
        << "  </Control>\n"
        << "  <Material>\n"
        << "    <material id=\"1\" name=\"tissue\" type=\"isotropic elastic\">\n"
        << "      <density>1</density>\n"
        << "      <E type=\"map\">E_map</E>\n"
        << "      <v>" << poisson_ratio << "</v>\n"
        << "    </material>\n"
        << "  </Material>\n"
        << "  <Mesh>\n"
        << "    <Nodes name=\"nodes\">\n";
    for (std::size_t i = 0; i < world.n_points(); ++i) {
      const auto& p = world.points[i];
      out << "      <node id=\"" << i + 1 << "\">" << p[0] << ',' << p[1] << ',' << p[2] << "</node>\n";
    }
    out << "    </Nodes>\n"
        << "    <Elements type=\"tet4\" name=\"Part1\">\n";
    for (std::size_t c = 0; c < m; ++c) {
      const auto& t = world.cells[c];
      out << "      <elem id=\"" << c + 1 << "\">" << t[0] + 1 << ',' << t[1] + 1 << ',' << t[2] + 1 << ','
          << t[3] + 1 << "</elem>\n";
    }
    out << "    </Elements>\n"
        << "  </Mesh>\n"
        << "  <MeshDomains>\n"
        << "    <SolidDomain name=\"Part1\" mat=\"tissue\"/>\n"
        << "  </MeshDomains>\n"
        << "  <MeshData>\n"
        << "    <ElementData name=\"E_map\" elem_set=\"Part1\">\n";
    for (std::size_t c = 0; c < m; ++c)
      out << "      <elem lid=\"" << c + 1 << "\">" << bins.element_modulus[c] << "</elem>\n";
    out << "    </ElementData>\n"
        << "  </MeshData>\n"
        << "</febio_spec>\n";
  });
}

}  // namespace vim::pipeline

// FEBio input (mesh.feb), febio_spec 4.0 (FEBio 4 user manual, chapter 3): Control (one static step),
// Material (FEBio's "isotropic elastic", St Venant–Kirchhoff, whose small-strain limit is the linear
// elasticity of the simulation, or for material.model neo-hookean FEBio's "neo-Hookean" with a
// nonlinear static step of 10 load increments; E is the per-element map E_map, each element's exact
// modulus; with --labels a domain, a material and a map per label, named by the label), Mesh
// (tet4, or tet10 for degree 2, nodes in world coordinates; node sets and surfaces of the image box
// faces and of every scenario region), MeshDomains, MeshData, and with a scenario Boundary (zero and
// prescribed displacement per world component), Loads (pressure and traction surface loads) and the
// load controller they ramp with. `febio4 -i mesh.feb`.
#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <vim/fem/material_description.hpp>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/exports.hpp>

#include "output/xml_text.hpp"

namespace vim::pipeline {

namespace {

const char* const dof_names[] = {"x", "y", "z"};

// Held (node, component) pairs grouped by (component, value): one node set held_<k> and one bc each.
std::map<std::pair<int, double>, std::vector<long>> held_groups(const SolverDeck<3>& deck) {
  std::map<std::pair<int, double>, std::vector<long>> groups;
  for (const auto& h : deck.held) groups[{h.component, h.value}].push_back(h.node);
  return groups;
}

void write_list(std::ostream& out, const std::vector<long>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i) out << (i ? "," : "") << ids[i] + 1;
}

// Surface facets with corners ordered so that the normal points out of the element (FEBio's pressure
// acts against it), mid-edge nodes after the corners.
void write_surface(std::ostream& out, const SolverDeck<3>& deck, const SolverDeck<3>::Set& s) {
  out << "    <Surface name=\"S_" << s.name << "\">\n";
  long id = 0;
  for (const auto& f : s.faces) {
    std::vector<long> n = deck.face_nodes(f);
    const auto& cell = deck.cells[f.cell];
    long opposite = cell[0];
    for (int k = 0; k < 4; ++k)
      if (std::find(n.begin(), n.begin() + 3, cell[k]) == n.begin() + 3) opposite = cell[k];
    const Eigen::Vector3d normal =
        (deck.nodes[n[1]] - deck.nodes[n[0]]).cross(deck.nodes[n[2]] - deck.nodes[n[0]]);
    if (normal.dot(deck.nodes[opposite] - deck.nodes[n[0]]) > 0.0) {  // inward: reverse the facet
      std::swap(n[1], n[2]);
      if (n.size() == 6) std::swap(n[3], n[5]);  // edges (0,2), (2,1), (1,0) after the swap
    }
    out << "      <" << (deck.degree == 2 ? "tri6" : "tri3") << " id=\"" << ++id << "\">";
    write_list(out, n);
    out << "</" << (deck.degree == 2 ? "tri6" : "tri3") << ">\n";
  }
  out << "    </Surface>\n";
}

void write_boundary_and_loads(std::ostream& out, const SolverDeck<3>& deck) {
  const auto groups = held_groups(deck);
  out << "  <Boundary>\n";
  int k = 0;
  for (const auto& [key, nodes] : groups) {
    const auto [c, value] = key;
    const std::string set = "held_" + std::to_string(++k);
    if (value == 0.0) {
      out << "    <bc name=\"" << set << "\" node_set=\"" << set << "\" type=\"zero displacement\">\n";
      for (int a = 0; a < 3; ++a)
        out << "      <" << dof_names[a] << "_dof>" << (a == c ? 1 : 0) << "</" << dof_names[a] << "_dof>\n";
    } else {
      out << "    <bc name=\"" << set << "\" node_set=\"" << set << "\" type=\"prescribed displacement\">\n"
          << "      <dof>" << dof_names[c] << "</dof>\n"
          << "      <value lc=\"1\">" << value << "</value>\n"
          << "      <relative>0</relative>\n";
    }
    out << "    </bc>\n";
  }
  out << "  </Boundary>\n  <Loads>\n";
  for (const auto& load : deck.surface_loads) {
    const auto& s = deck.regions[load.region];
    if (s.faces.empty()) continue;
    if (load.is_pressure) {
      out << "    <surface_load name=\"" << s.name << "\" surface=\"S_" << s.name << "\" type=\"pressure\">\n"
          << "      <pressure lc=\"1\">" << load.pressure << "</pressure>\n"
          << "      <linear>1</linear>\n"
          << "      <symmetric_stiffness>1</symmetric_stiffness>\n";
    } else {
      out << "    <surface_load name=\"" << s.name << "\" surface=\"S_" << s.name << "\" type=\"traction\">\n"
          << "      <scale lc=\"1\">1</scale>\n"
          << "      <traction>" << load.traction[0] << ',' << load.traction[1] << ',' << load.traction[2]
          << "</traction>\n";
    }
    out << "    </surface_load>\n";
  }
  out << "  </Loads>\n"
      << "  <LoadData>\n"
      << "    <load_controller id=\"1\" name=\"LC1\" type=\"loadcurve\">\n"
      << "      <interpolate>LINEAR</interpolate>\n"
      << "      <points>\n        <pt>0,0</pt>\n        <pt>1,1</pt>\n      </points>\n"
      << "    </load_controller>\n"
      << "  </LoadData>\n";
}

// The parts (FEBio element blocks, one domain each): Part1 holding every element, or with --labels one
// per label, named by the label's name, in ascending label order.
std::vector<std::pair<std::string, std::vector<long>>> feb_parts(const SolverDeck<3>& deck) {
  if (deck.label.empty()) {
    std::vector<long> all(deck.cells.size());
    for (std::size_t c = 0; c < all.size(); ++c) all[c] = static_cast<long>(c);
    return {{"Part1", all}};
  }
  std::map<int, std::vector<long>> by_label;
  for (std::size_t c = 0; c < deck.cells.size(); ++c) by_label[deck.label[c]].push_back(static_cast<long>(c));
  std::vector<std::pair<std::string, std::vector<long>>> parts;
  for (auto& [label, cells] : by_label) {
    const auto name = deck.label_name.find(label);
    parts.emplace_back(name != deck.label_name.end() ? name->second : "label_" + std::to_string(label),
                       std::move(cells));
  }
  return parts;
}

void write_mesh(std::ostream& out, const SolverDeck<3>& deck) {
  out << "  <Mesh>\n    <Nodes name=\"nodes\">\n";
  for (std::size_t i = 0; i < deck.nodes.size(); ++i) {
    const auto& p = deck.nodes[i];
    out << "      <node id=\"" << i + 1 << "\">" << p[0] << ',' << p[1] << ',' << p[2] << "</node>\n";
  }
  const char* type = deck.degree == 2 ? "tet10" : "tet4";
  out << "    </Nodes>\n";
  for (const auto& [name, cells] : feb_parts(deck)) {
    out << "    <Elements type=\"" << type << "\" name=\"" << name << "\">\n";
    for (long c : cells) {
      out << "      <elem id=\"" << c + 1 << "\">";
      write_list(out, deck.cells[static_cast<std::size_t>(c)]);
      out << "</elem>\n";
    }
    out << "    </Elements>\n";
  }
  auto sets = [&](const SolverDeck<3>::Set& s) {
    if (!s.nodes.empty()) {
      out << "    <NodeSet name=\"N_" << s.name << "\">";
      write_list(out, s.nodes);
      out << "</NodeSet>\n";
    }
    if (!s.faces.empty()) write_surface(out, deck, s);
  };
  for (const auto& s : deck.box_faces) sets(s);
  for (const auto& s : deck.regions) sets(s);
  int k = 0;
  for (const auto& [key, nodes] : held_groups(deck)) {
    out << "    <NodeSet name=\"held_" << ++k << "\">";
    write_list(out, nodes);
    out << "</NodeSet>\n";
  }
  out << "  </Mesh>\n";
}

}  // namespace

void write_feb(const std::filesystem::path& path, const SolverDeck<3>& deck) {
  write_text_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n"
        << xml_comment("vim-pipeline model, world coordinates; E per element in MeshData/E_map (exact)")
        << "\n";
    if (!deck.neo_hookean)
      out << xml_comment(
                 "Material: FEBio's isotropic elastic is St Venant-Kirchhoff, which equals the simulation's\n"
                 "     small-strain linear elasticity at small strain (the first-order terms agree).")
          << "\n";
    if (!deck.has_conditions)
      out << xml_comment(
                 "Mesh and materials only: no conditions (run vim-pipeline with a scenario, option simulate, "
                 "for a complete model)")
          << "\n";
    for (const auto& what : deck.not_expressed) out << xml_comment("Not in this model: " + what) << "\n";
    if (deck.neo_hookean)
      out << xml_comment(
                 "Material: material.model neo-hookean as FEBio's neo-Hookean, W = mu/2 (I1 - 3) - mu ln J "
                 "+\n"
                 "     lambda/2 (ln J)^2, the closest FEBio material to the simulation's W = C10 (I1bar - 3) "
                 "+\n"
                 "     (J - 1)^2/D1 (same mu and lambda, another volumetric term: at 15 % uniaxial "
                 "compression\n"
                 "     its stress is 1.5 % lower for nu = 0.45, 4.3 % for nu = 0.3; docs/finite-strain.md).\n"
                 "     Nonlinear static step: 10 steps of 0.1, automatic step control.")
          << "\n";
    out << "<febio_spec version=\"4.0\">\n"
        << "  <Module type=\"solid\"/>\n"
        << "  <Control>\n"
        << "    <analysis>STATIC</analysis>\n";
    if (deck.neo_hookean)
      out << "    <time_steps>10</time_steps>\n"
          << "    <step_size>0.1</step_size>\n"
          << "    <time_stepper type=\"default\">\n"
          << "      <max_retries>10</max_retries>\n"
          << "      <opt_iter>10</opt_iter>\n"
          << "      <dtmin>0.0001</dtmin>\n"
          << "      <dtmax>0.1</dtmax>\n"
          << "    </time_stepper>\n";
    else
      out << "    <time_steps>1</time_steps>\n"
          << "    <step_size>1</step_size>\n";
    out << "  </Control>\n"
        << "  <Material>\n";
    // One material per part ("tissue" with its map "E_map", or per label tissue_NAME with E_map_NAME).
    const auto parts = feb_parts(deck);
    const bool one = deck.label.empty();
    const auto suffix = [&](const std::string& name) { return one ? std::string() : "_" + name; };
    int id = 0;
    for (const auto& part : parts)
      fem::MaterialDescription{deck.poisson_ratio, deck.neo_hookean}.write_feb_material(
          out, ++id, "tissue" + suffix(part.first), "E_map" + suffix(part.first));
    out << "  </Material>\n";
    write_mesh(out, deck);
    out << "  <MeshDomains>\n";
    for (const auto& part : parts)
      out << "    <SolidDomain name=\"" << part.first << "\" mat=\"tissue" << suffix(part.first) << "\"/>\n";
    out << "  </MeshDomains>\n"
        << "  <MeshData>\n";
    for (const auto& [name, cells] : parts) {
      out << "    <ElementData type=\"scalar\" name=\"E_map" << suffix(name) << "\" elem_set=\"" << name
          << "\">\n";
      for (std::size_t i = 0; i < cells.size(); ++i)
        out << "      <e lid=\"" << i + 1 << "\">" << deck.modulus[static_cast<std::size_t>(cells[i])]
            << "</e>\n";
      out << "    </ElementData>\n";
    }
    out << "  </MeshData>\n";
    if (deck.has_conditions) write_boundary_and_loads(out, deck);
    out << "  <Output>\n    <plotfile type=\"febio\">\n      <var type=\"displacement\"/>\n    </plotfile>\n "
           " </Output>\n"
        << "</febio_spec>\n";
  });
}

}  // namespace vim::pipeline

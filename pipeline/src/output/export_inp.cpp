// CalculiX/Abaqus input deck (mesh.inp): the heading (with the scenario features the deck does not
// hold), *NODE (NSET=NALL), one *ELEMENT block per distinct modulus (C3D4/C3D10, CPE3/CPE6 plane strain
// of unit thickness, as fem/; with --labels one per label and modulus, and an element set L_NAME per
// label), node sets and element-face surfaces of the image box faces and of every
// scenario region, one *MATERIAL per distinct modulus (exact, 17 significant digits), and with a
// scenario one *STEP with *STATIC: *BOUNDARY per held node and world component, *DSLOAD pressures,
// *CLOAD consistent nodal forces of the tractions, *NODE PRINT / *NODE FILE of U. `ccx -i mesh`. With
// material.model neo-hookean: *HYPERELASTIC, NEO HOOKE cards, *STEP, NLGEOM and the pressures as dead
// nodal forces (solver_deck.hpp).
#include <map>
#include <vim/fem/material_description.hpp>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/exports.hpp>

namespace vim::pipeline {

namespace {

// Abaqus data lines hold at most 16 entries.
void write_id_list(std::ostream& out, const std::vector<long>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    out << ids[i] + 1 << ((i % 16 == 15 || i + 1 == ids.size()) ? "\n" : ", ");
}

template <int dim>
void write_sets(std::ostream& out, const SolverDeck<dim>& deck) {
  auto write = [&](const typename SolverDeck<dim>::Set& s) {
    out << "** " << s.name << ": " << s.description << '\n';
    if (!s.nodes.empty()) {
      out << "*Nset, NSET=N_" << s.name << '\n';
      write_id_list(out, s.nodes);
    }
    if (!s.faces.empty()) {
      out << "*Surface, NAME=S_" << s.name << ", TYPE=ELEMENT\n";
      for (const auto& f : s.faces) out << f.cell + 1 << ", S" << f.face + 1 << '\n';
    }
  };
  for (const auto& s : deck.box_faces) write(s);
  for (const auto& s : deck.regions) write(s);
}

template <int dim>
void write_step(std::ostream& out, const SolverDeck<dim>& deck) {
  // neo-Hookean: geometrically nonlinear, in increments of the load (CalculiX's automatic stepping)
  if (deck.neo_hookean)
    out << "*Step, NLGEOM, INC=1000\n*Static, SOLVER=SPOOLES\n0.1, 1.0, 1e-05, 0.25\n";
  else
    out << "*Step\n*Static, SOLVER=SPOOLES\n";
  if (!deck.held.empty()) {
    out << "*Boundary\n";
    for (const auto& h : deck.held)
      out << h.node + 1 << ", " << h.component + 1 << ", " << h.component + 1 << ", " << h.value << '\n';
  }
  for (const auto& load : deck.surface_loads)
    if (load.is_pressure && !deck.neo_hookean && !deck.regions[load.region].faces.empty())
      out << "*Dsload\nS_" << deck.regions[load.region].name << ", P, " << load.pressure << '\n';
  if (!deck.nodal_forces.empty()) {
    out << "*Cload\n";
    for (const auto& [node, f] : deck.nodal_forces)
      for (int c = 0; c < dim; ++c)
        if (f[c] != 0.0) out << node + 1 << ", " << c + 1 << ", " << f[c] << '\n';
  }
  out << "*Node Print, NSET=NALL\nU\n*Node File\nU\n*End Step\n";
}

}  // namespace

template <int dim>
void write_inp(const std::filesystem::path& path, const SolverDeck<dim>& deck) {
  // One material per (label, exact modulus): no binning, and with --labels no material shared by two labels.
  std::map<std::pair<int, double>, std::vector<long>> by_modulus;
  std::map<int, std::vector<long>> by_label;
  for (std::size_t c = 0; c < deck.cells.size(); ++c) {
    const int label = deck.label.empty() ? 0 : deck.label[c];
    by_modulus[{label, deck.modulus[c]}].push_back(static_cast<long>(c));
    if (!deck.label.empty()) by_label[label].push_back(static_cast<long>(c));
  }
  const char* type = dim == 3 ? (deck.degree == 2 ? "C3D10" : "C3D4") : (deck.degree == 2 ? "CPE6" : "CPE3");
  write_text_atomically(path, [&](std::ostream& out) {
    out << "*Heading\nvim-pipeline model, world coordinates, " << type << ", " << by_modulus.size()
        << " distinct moduli (one material each)";
    if (!by_label.empty()) out << ", " << by_label.size() << " labels (element sets L_NAME)";
    if (!deck.has_conditions)
      out << "; mesh and materials only (no conditions: run with --simulate for a complete job)";
    out << '\n';
    for (const auto& what : deck.not_expressed) out << "** Not in this deck: " << what << '\n';
    out << "*Node, NSET=NALL\n";
    for (std::size_t i = 0; i < deck.nodes.size(); ++i) {
      out << i + 1;
      for (int a = 0; a < dim; ++a) out << ", " << deck.nodes[i][a];
      out << '\n';
    }
    std::size_t k = 0;
    for (const auto& [E, members] : by_modulus) {
      out << "*Element, TYPE=" << type << ", ELSET=MAT_" << ++k << '\n';
      for (long c : members) {
        out << c + 1;
        for (long v : deck.cells[c]) out << ", " << v + 1;
        out << '\n';
      }
    }
    for (const auto& [label, members] : by_label) {  // --labels: an element set per label
      const auto name = deck.label_name.find(label);
      out << "*Elset, ELSET=L_"
          << (name != deck.label_name.end() ? name->second : "label_" + std::to_string(label)) << '\n';
      write_id_list(out, members);
    }
    write_sets(out, deck);
    k = 0;
    for (const auto& entry : by_modulus) {
      (void)entry;
      ++k;
      out << "*Solid Section, ELSET=MAT_" << k << ", MATERIAL=MATERIAL_" << k << '\n'
          << (dim == 2 ? "1.0\n" : "\n");  // 2D: unit thickness
    }
    k = 0;
    const fem::MaterialDescription material{deck.poisson_ratio, deck.neo_hookean};
    for (const auto& [key, members] : by_modulus) {
      out << "*Material, NAME=MATERIAL_" << ++k << '\n';
      material.write_inp_card(out, key.second);
    }
    if (deck.has_conditions) write_step(out, deck);
  });
}

template void write_inp<2>(const std::filesystem::path&, const SolverDeck<2>&);
template void write_inp<3>(const std::filesystem::path&, const SolverDeck<3>&);

}  // namespace vim::pipeline

// Truth: the tools the exports are for. CalculiX (ccx) solves the exported mesh.inp of a 3D and a 2D
// scenario with P1 and P2 elements, and its nodal displacements must equal our deal.II solution of
// the same scenario (step 0, the state under the boundary conditions) within 1e-6 of the largest
// displacement: C3D4/CPE3 and C3D10/CPE6 with full integration assemble the same stiffness as deal.II's
// P1/P2 with QGaussSimplex, and the loads are exact for constant pressure and traction. Gmsh reads
// mesh.msh and re-saves it; the node, element and physical-group counts it keeps must be those of the
// Kuhn grid counted independently. Python's XML parser checks mesh.feb against febio_spec 4.0's
// required structure. A test skips (GTEST_SKIP) only when the tool is not installed.
#include <gtest/gtest.h>
#include <vtkCellTypes.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <vim/fem/finite_strain.hpp>
#include <vim/pipeline/output/exports.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "gmsh_view.hpp"
#include "oblique_grid.hpp"
#include "run_cli.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim;
using namespace vim::pipeline;

namespace {

bool have_program(const std::string& name) {
  return std::system(("command -v " + name + " > /dev/null 2>&1").c_str()) == 0;
}

std::string fmt(double x) {
  std::ostringstream s;
  s.precision(17);
  s << x;
  return s.str();
}

template <int dim>
std::string vec_yaml(const Eigen::Matrix<double, dim, 1>& v) {
  std::string s = "[";
  for (int a = 0; a < dim; ++a) s += (a ? ", " : "") + fmt(v[a]);
  return s + "]";
}

// A Kuhn grid of an oblique image box with a heterogeneous element mean (the modulus, scale 1).
template <int dim>
MeshModel<dim> oblique_model(const std::array<int, dim>& nodes) {
  MeshModel<dim> m = vim::test::oblique_grid<dim>(nodes);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    ElementValue v;
    v.mean = 20.0 + 15.0 * std::sin(0.7 * static_cast<double>(c)) + 1e-7 * static_cast<double>(c);
    v.voxels = 1;
    m.values.push_back(v);
  }
  return m;
}

// Every kind of condition: held faces, a prescribed displacement, a pressure, a traction, world
// components held on a face and in a sphere (along the world axes, which are oblique to the image).
template <int dim>
Scenario scenario_for(const MeshModel<dim>& m) {
  using P = Eigen::Matrix<double, dim, 1>;
  P lo = m.mesh.points[0], hi = lo;
  for (const auto& p : m.mesh.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const auto& tf = m.transform;
  P entry_frame = 0.5 * (lo + hi);
  entry_frame[dim - 1] = lo[dim - 1];
  const P axis = tf.vector_to_world(P::Unit(dim - 1));
  const P centre = tf.to_world(0.5 * (lo + hi));
  const std::string last = dim == 3 ? "z" : "y";
  std::string y = "material: {youngs_modulus: image, poisson_ratio: 0.3}\nboundary_conditions:\n";
  y += "  - {type: fixed, region: {box_face: " + last + "_min}}\n";
  y += "  - {type: displacement, region: {box_face: " + last +
       "_max}, value: " + (dim == 3 ? std::string("[0.01, -0.02, -0.05]") : std::string("[0.01, -0.03]")) +
       "}\n";
  y += "  - {type: fixed, region: {box_face: x_min}, components: [y]}\n";
  y += "  - {type: fixed, region: {sphere: {center: " + vec_yaml<dim>(centre) +
       ", radius: 0.9}}, components: [x]}\n";
  y += "  - {type: pressure, region: {box_face: x_max}, value: 0.3}\n";
  y += std::string("  - {type: traction, region: {box_face: ") + (dim == 3 ? "y_max" : "x_min") +
       "}, value: " + (dim == 3 ? std::string("[0.05, 0.1, 0.2]") : std::string("[0.05, 0.1]")) + "}\n";
  y += "needle: {entry: " + vec_yaml<dim>(tf.to_world(entry_frame)) + ", direction: " + vec_yaml<dim>(axis) +
       ", depth: 1.0, steps: 2, diameter: 0.1, friction: {model: stick}}\n";
  return parse_scenario_text(y, dim, "deck_scenario.yaml");
}

// Nodal displacements of `ccx -i mesh` in dir (mesh.dat, *NODE PRINT of NALL), by 1-based node number.
std::map<long, Eigen::Vector3d> run_calculix(const fs::path& dir) {
  const std::string cmd = "cd '" + dir.string() + "' && ccx -i mesh > ccx.log 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << "ccx failed; see " << (dir / "ccx.log");
  std::ifstream in(dir / "mesh.dat");
  std::map<long, Eigen::Vector3d> u;
  std::string line;
  bool in_block = false;
  while (std::getline(in, line)) {
    if (line.find("displacements") != std::string::npos) {
      in_block = true;
      continue;
    }
    if (!in_block) continue;
    std::istringstream s(line);
    long node;
    Eigen::Vector3d v;
    if (s >> node >> v[0] >> v[1] >> v[2]) u[node] = v;
  }
  return u;
}

template <int dim>
struct OurSolution {
  std::vector<Eigen::Matrix<double, dim, 1>> nodes;  // per deck node, world axes
  double largest = 0.0;
};

// Our step-0 solution at the deck's nodes: vertex values and, for P2, the mid-edge DoF values.
template <int dim>
OurSolution<dim> our_solution(NeedleSimulation<dim>& sim, const MeshModel<dim>& m,
                              const SolverDeck<dim>& deck, bool neo_hookean = false) {
  const fem::Solution<dim> s =
      neo_hookean ? fem::solve_neo_hookean(sim.model()).solution : sim.model().solve();
  OurSolution<dim> out;
  for (const auto& u : s.vertex_displacement) out.nodes.push_back(m.transform.vector_to_world(u));
  if (deck.degree == 2)
    for (const auto& u : sim.model().edge_midpoint_displacement(deck.edges))
      out.nodes.push_back(m.transform.vector_to_world(u));
  for (const auto& u : out.nodes) out.largest = std::max(out.largest, u.norm());
  return out;
}

template <int dim>
void expect_calculix_agrees(unsigned degree, const std::array<int, dim>& nodes) {
  if (!have_program("ccx")) GTEST_SKIP() << "CalculiX (ccx, Debian package calculix-ccx) is not installed";
  const auto dir =
      vim::test::scratch_dir("decks", "ccx" + std::to_string(dim) + "d_p" + std::to_string(degree));
  MeshModel<dim> m = oblique_model<dim>(nodes);
  const Scenario sc = scenario_for(m);
  SimulationOptions so;
  so.degree = degree;
  so.progress = false;
  NeedleSimulation<dim> sim(m, sc, so);
  m.youngs_modulus = sim.youngs_modulus();
  ExportOptions eo;
  eo.poisson_ratio = sc.poisson_ratio;
  eo.scenario = &sc;
  eo.degree = degree;
  nlohmann::json report;
  report["exports"] = write_exports<dim>(m, dir, {"inp"}, eo);
  const SolverDeck<dim> deck = solver_deck(m, world_mesh(m), m.youngs_modulus, sc.poisson_ratio, degree, &sc);
  const OurSolution<dim> ours = our_solution(sim, m, deck);
  ASSERT_GT(ours.largest, 1e-3);
  const auto theirs = run_calculix(dir);
  ASSERT_EQ(theirs.size(), deck.nodes.size()) << "CalculiX printed another node count";
  double worst = 0.0;
  for (std::size_t i = 0; i < deck.nodes.size(); ++i) {
    const Eigen::Vector3d& t = theirs.at(static_cast<long>(i) + 1);
    for (int a = 0; a < dim; ++a) worst = std::max(worst, std::abs(t[a] - ours.nodes[i][a]));
    if (dim == 2) {
      EXPECT_NEAR(t[2], 0.0, 1e-12 + 1e-9 * ours.largest);
    }
  }
  EXPECT_LE(worst, 1e-6 * ours.largest) << "largest displacement " << ours.largest;
  ::testing::Test::RecordProperty("ccx_max_difference_over_largest", fmt(worst / ours.largest));
  std::cout << "CalculiX vs deal.II, " << dim << "D P" << degree << ": " << deck.nodes.size()
            << " nodes, max |Δu| / max |u| = " << worst / ours.largest << '\n';
}

// material.model neo-hookean, static: the heterogeneous oblique block held on its last-axis minimum face,
// the opposite face moved by 20% of the height inwards and 4% across (world axes, oblique to the
// grid), a pressure (dead: nodal forces in the deck) and a traction on two side faces.
template <int dim>
Scenario neo_hookean_scenario(const MeshModel<dim>& m) {
  using P = Eigen::Matrix<double, dim, 1>;
  P lo = m.mesh.points[0], hi = lo;
  for (const auto& p : m.mesh.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double height = hi[dim - 1] - lo[dim - 1];
  const P move = m.transform.vector_to_world(-0.2 * height * P::Unit(dim - 1) + 0.04 * height * P::Unit(0));
  const std::string last = dim == 3 ? "z" : "y";
  std::string y = "material: {model: neo-hookean, youngs_modulus: image, poisson_ratio: 0.3}\n";
  y += "boundary_conditions:\n  - {type: fixed, region: {box_face: " + last + "_min}}\n";
  y += "  - {type: displacement, region: {box_face: " + last + "_max}, value: " + vec_yaml<dim>(move) + "}\n";
  y += "  - {type: pressure, region: {box_face: x_max}, value: 0.5}\n";
  y += "  - {type: traction, region: {box_face: x_min}, value: " +
       (dim == 3 ? std::string("[0.1, 0.2, 0.3]") : std::string("[0.1, 0.2]")) + "}\n";
  return parse_scenario_text(y, dim, "neo_hookean_deck.yaml");
}

// CalculiX runs the exported neo-Hookean deck as written; its nodal displacements equal our Newton
// solve's within 0.5% of the largest.
template <int dim>
void expect_calculix_agrees_neo_hookean(unsigned degree, const std::array<int, dim>& nodes) {
  if (!have_program("ccx")) GTEST_SKIP() << "CalculiX (ccx, Debian package calculix-ccx) is not installed";
  const auto dir =
      vim::test::scratch_dir("decks", "ccx_nh" + std::to_string(dim) + "d_p" + std::to_string(degree));
  MeshModel<dim> m = oblique_model<dim>(nodes);
  const Scenario sc = neo_hookean_scenario(m);
  SimulationOptions so;
  so.degree = degree;
  so.progress = false;
  NeedleSimulation<dim> sim(m, sc, so);
  m.youngs_modulus = sim.youngs_modulus();
  ExportOptions eo;
  eo.poisson_ratio = sc.poisson_ratio;
  eo.scenario = &sc;
  eo.degree = degree;
  write_exports<dim>(m, dir, {"inp"}, eo);
  std::ifstream deck_file(dir / "mesh.inp");
  std::stringstream text;
  text << deck_file.rdbuf();
  EXPECT_NE(text.str().find("*Hyperelastic, NEO HOOKE"), std::string::npos);
  EXPECT_NE(text.str().find("*Step, NLGEOM"), std::string::npos);
  EXPECT_EQ(text.str().find("*Dsload"), std::string::npos) << "pressures are dead nodal forces";
  const SolverDeck<dim> deck = solver_deck(m, world_mesh(m), m.youngs_modulus, sc.poisson_ratio, degree, &sc);
  const OurSolution<dim> ours = our_solution(sim, m, deck, true);
  ASSERT_GT(ours.largest, 1e-3);
  const auto theirs = run_calculix(dir);
  ASSERT_EQ(theirs.size(), deck.nodes.size()) << "CalculiX printed another node count";
  double worst = 0.0;
  for (std::size_t i = 0; i < deck.nodes.size(); ++i) {
    const Eigen::Vector3d& t = theirs.at(static_cast<long>(i) + 1);
    for (int a = 0; a < dim; ++a) worst = std::max(worst, std::abs(t[a] - ours.nodes[i][a]));
  }
  EXPECT_LE(worst, 5e-3 * ours.largest) << "largest displacement " << ours.largest;
  ::testing::Test::RecordProperty("ccx_max_difference_over_largest", fmt(worst / ours.largest));
  std::cout << "CalculiX NLGEOM vs neo-Hookean Newton, " << dim << "D P" << degree << ": "
            << deck.nodes.size() << " nodes, max |Δu| / max |u| = " << worst / ours.largest << '\n';
}

}  // namespace

TEST(SolverDecks, CalculixSolvesNeoHookeanDeckLikeOurNewton3DP2) {
  expect_calculix_agrees_neo_hookean<3>(2, {{4, 4, 5}});
}
TEST(SolverDecks, CalculixSolvesNeoHookeanDeckLikeOurNewton3DP1) {
  expect_calculix_agrees_neo_hookean<3>(1, {{5, 5, 6}});
}
TEST(SolverDecks, CalculixSolvesNeoHookeanDeckLikeOurNewton2DP2) {
  expect_calculix_agrees_neo_hookean<2>(2, {{6, 7}});
}

TEST(SolverDecks, CalculixSolves3DP1DeckLikeDealII) { expect_calculix_agrees<3>(1, {{5, 5, 6}}); }
TEST(SolverDecks, CalculixSolves3DP2DeckLikeDealII) { expect_calculix_agrees<3>(2, {{5, 5, 5}}); }
TEST(SolverDecks, CalculixSolves2DP1DeckLikeDealII) { expect_calculix_agrees<2>(1, {{9, 11}}); }
TEST(SolverDecks, CalculixSolves2DP2DeckLikeDealII) { expect_calculix_agrees<2>(2, {{6, 7}}); }

TEST(SolverDecks, GmshReadsQuadraticMeshWithEveryGroup) {
  if (!have_program("gmsh")) GTEST_SKIP() << "Gmsh (gmsh, Debian package gmsh) is not installed";
  const auto dir = vim::test::scratch_dir("decks", "gmsh");
  const std::array<int, 3> n{{4, 5, 6}};
  MeshModel<3> m = oblique_model<3>(n);
  const Scenario sc = scenario_for(m);
  ExportOptions eo;
  eo.scenario = &sc;
  eo.degree = 2;
  nlohmann::json report;
  report["exports"] = write_exports<3>(m, dir, {"msh"}, eo);
  vim::test::GmshView g = vim::test::gmsh_view(dir / "mesh.msh");

  // Independent counts of the Kuhn grid: vertices, distinct edges, cells, triangles per box face.
  std::set<std::pair<int, int>> edges;
  for (const auto& c : m.mesh.cells)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) edges.insert({std::min(c[a], c[b]), std::max(c[a], c[b])});
  const long vertices = static_cast<long>(n[0]) * n[1] * n[2];
  EXPECT_EQ(g.nodes, vertices + static_cast<long>(edges.size()));
  EXPECT_EQ(g.elements_of_type[11], 6L * (n[0] - 1) * (n[1] - 1) * (n[2] - 1));  // 10-node tetrahedra
  auto face_triangles = [&](int a, int b) { return 2L * (n[a] - 1) * (n[b] - 1); };
  const std::map<std::string, long> faces = {{"x_min", face_triangles(1, 2)},
                                             {"x_max", face_triangles(1, 2)},
                                             {"y_min", face_triangles(0, 2)},
                                             {"y_max", face_triangles(0, 2)},
                                             {"z_min", face_triangles(0, 1)},
                                             {"z_max", face_triangles(0, 1)},
                                             {"BC1_fixed", face_triangles(0, 1)},         // z_min
                                             {"BC2_displacement", face_triangles(0, 1)},  // z_max
                                             {"BC3_fixed", face_triangles(1, 2)},         // x_min
                                             {"BC5_pressure", face_triangles(1, 2)},      // x_max
                                             {"BC6_traction", face_triangles(0, 2)}};     // y_max
  long all_faces = 0;
  for (const auto& [name, count] : faces) {
    EXPECT_EQ(g.elements_of_group[name], count) << name;
    all_faces += count;
  }
  EXPECT_EQ(g.elements_of_type[9], all_faces);  // 6-node triangles
  // Node groups: a box face holds its grid vertices and the midpoints of its edges (rows, columns,
  // diagonals of the face's Kuhn triangulation); the sphere the vertices and midpoints within its radius.
  auto face_nodes = [&](int a, int b) {
    return static_cast<long>(n[a]) * n[b] + (n[a] - 1L) * n[b] + n[a] * (n[b] - 1L) +
           (n[a] - 1L) * (n[b] - 1L);
  };
  EXPECT_EQ(g.elements_of_group["BC1_fixed_nodes"], face_nodes(0, 1));
  EXPECT_EQ(g.elements_of_group["BC6_traction_nodes"], face_nodes(0, 2));
  const Eigen::Vector3d centre = 0.5 * (m.mesh.points.front() + m.mesh.points.back());
  long in_sphere = 0;
  for (const auto& p : m.mesh.points) in_sphere += (p - centre).norm() <= 0.9 ? 1 : 0;
  for (const auto& [a, b] : edges)
    in_sphere += (0.5 * (m.mesh.points[a] + m.mesh.points[b]) - centre).norm() <= 0.9 ? 1 : 0;
  ASSERT_GT(in_sphere, 0);
  EXPECT_EQ(g.elements_of_group["BC4_fixed_nodes"], in_sphere);
  EXPECT_EQ(g.elements_of_group.count("BC4_fixed"), 0u) << "the sphere touches no boundary face";
  long materials = 0;
  for (const auto& [name, count] : g.elements_of_group)
    materials += name.rfind("material_", 0) == 0 ? count : 0;
  EXPECT_EQ(materials, g.elements_of_type[11]);
}

namespace {
std::string feb_check(const fs::path& feb) {
  const std::string cmd = "/usr/bin/python3 '" + std::string(VIM_SOURCE_DIR) +
                          "/tests/support/feb_structure.py' '" + feb.string() + "' > '" + feb.string() +
                          ".check' 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(feb.string() + ".check");
  std::string first;
  std::getline(in, first);
  return first.empty() ? "no output, exit status " + std::to_string(status) : first;
}
}  // namespace

TEST(SolverDecks, FebioDeckHasTheRequiredStructure) {
  if (!fs::exists("/usr/bin/python3"))
    GTEST_SKIP() << "/usr/bin/python3 (its xml.etree checks mesh.feb) is missing";
  const auto dir = vim::test::scratch_dir("decks", "feb");
  MeshModel<3> m = oblique_model<3>({{4, 4, 5}});
  const Scenario sc = scenario_for(m);
  for (unsigned degree : {1u, 2u}) {
    ExportOptions eo;
    eo.scenario = &sc;
    eo.degree = degree;
    eo.poisson_ratio = sc.poisson_ratio;
    nlohmann::json report;
    report["exports"] = write_exports<3>(m, dir, {"feb"}, eo);
    EXPECT_EQ(feb_check(dir / "mesh.feb"), "OK") << "degree " << degree;
    std::ifstream in(dir / "mesh.feb");
    std::stringstream text;
    text << in.rdbuf();
    const std::string xml = text.str();
    EXPECT_NE(xml.find(degree == 2 ? "type=\"tet10\"" : "type=\"tet4\""), std::string::npos);
    EXPECT_NE(xml.find("St Venant-Kirchhoff"), std::string::npos);
    EXPECT_NE(xml.find("Not in this model: the insertion of needle"), std::string::npos);
    // The checker can fail: a bc whose node set is missing is reported.
    std::string broken = xml;
    const std::string held = "<NodeSet name=\"held_1\">";
    ASSERT_NE(broken.find(held), std::string::npos);
    broken.replace(broken.find(held), held.size(), "<NodeSet name=\"other\">");
    std::ofstream(dir / "broken.feb") << broken;
    EXPECT_EQ(feb_check(dir / "broken.feb").rfind("FAIL: bc held_1: node set missing", 0), 0u);
  }
}

// material.model neo-hookean: mesh.feb passes the febio_spec 4.0 structure check (Python's XML parser) and
// carries FEBio's neo-Hookean material with the per-element E map and the scenario's ν, and a static step
// of 10 increments; the linear model's deck keeps FEBio's isotropic elastic in one step.
TEST(SolverDecks, FebioDeckCarriesTheNeoHookeanMaterialAndANonlinearStep) {
  if (!fs::exists("/usr/bin/python3"))
    GTEST_SKIP() << "/usr/bin/python3 (its xml.etree checks mesh.feb) is missing";
  const auto dir = vim::test::scratch_dir("decks", "feb_nh");
  MeshModel<3> m = oblique_model<3>({{4, 4, 5}});
  for (const bool neo : {true, false}) {
    const Scenario sc = neo ? neo_hookean_scenario(m) : scenario_for(m);
    ExportOptions eo;
    eo.scenario = &sc;
    eo.degree = 2;
    eo.poisson_ratio = sc.poisson_ratio;
    write_exports<3>(m, dir, {"feb"}, eo);
    EXPECT_EQ(feb_check(dir / "mesh.feb"), "OK") << "neo-Hookean " << neo;
    std::ifstream in(dir / "mesh.feb");
    std::stringstream text;
    text << in.rdbuf();
    const std::string xml = text.str();
    const auto at = xml.find("<material id=\"1\" name=\"tissue\" type=\"");
    ASSERT_NE(at, std::string::npos);
    const std::string material = xml.substr(at, xml.find("</material>", at) - at);
    EXPECT_NE(material.find(neo ? "type=\"neo-Hookean\"" : "type=\"isotropic elastic\""), std::string::npos)
        << material;
    EXPECT_NE(material.find("<E type=\"map\">E_map</E>"), std::string::npos) << material;
    ASSERT_NE(material.find("<v>"), std::string::npos) << material;
    EXPECT_NEAR(std::stod(material.substr(material.find("<v>") + 3)), 0.3, 1e-15) << material;
    EXPECT_NE(xml.find(neo ? "<time_steps>10</time_steps>" : "<time_steps>1</time_steps>"),
              std::string::npos);
    EXPECT_EQ(xml.find("<time_stepper") != std::string::npos, neo);
    EXPECT_EQ(xml.find("Not in this model: material.model"), std::string::npos);
  }
}

// Truth: deal.II's point evaluation (ElasticModel::sample, point location + FEValues) of the last step at
// every point of the step VTU: the mid-edge points carry the P2 field, not an average of the vertices.
TEST(SolverDecks, P2StepVtuHoldsQuadraticCellsWithTheP2Field) {
  const auto dir = vim::test::scratch_dir("decks", "vtu");
  MeshModel<3> m = oblique_model<3>({{5, 5, 5}});
  const Scenario sc = scenario_for(m);
  SimulationOptions so;
  so.degree = 2;
  so.progress = false;
  so.output_file = [&](const std::string& rel) {
    fs::create_directories((dir / rel).parent_path());
    return dir / rel;
  };
  NeedleSimulation<3> sim(m, sc, so);
  sim.run();
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((dir / "steps" / "step_0002.vtu").string().c_str());
  reader->Update();
  vtkUnstructuredGrid* g = reader->GetOutput();
  ASSERT_EQ(g->GetNumberOfCells(), static_cast<vtkIdType>(m.mesh.n_cells()));
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c)
    ASSERT_EQ(g->GetCellType(c), 24);  // VTK_QUADRATIC_TETRA
  vtkDataArray* u = g->GetPointData()->GetArray("displacement");
  ASSERT_NE(u, nullptr);
  std::vector<Eigen::Vector3d> frame_points;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double x[3];
    g->GetPoint(i, x);
    frame_points.push_back(m.transform.to_frame(Eigen::Vector3d(x[0], x[1], x[2])));
  }
  ASSERT_GT(frame_points.size(), m.mesh.n_points());
  const auto expected = sim.model().sample(frame_points);
  double largest = 0.0, worst = 0.0, worst_linear = 0.0;
  for (std::size_t i = 0; i < frame_points.size(); ++i) {
    const Eigen::Vector3d e = m.transform.vector_to_world(expected[i]);
    const Eigen::Vector3d got(u->GetComponent(i, 0), u->GetComponent(i, 1), u->GetComponent(i, 2));
    largest = std::max(largest, e.norm());
    worst = std::max(worst, (got - e).norm());
  }
  // The P2 field is not linear between the vertices: averaging them would miss by far more.
  vtkIdType pts[10];
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
    vtkIdType npts;
    const vtkIdType* ids;
    g->GetCellPoints(c, npts, ids);
    std::copy(ids, ids + npts, pts);
    const Eigen::Vector3d a(u->GetComponent(pts[0], 0), u->GetComponent(pts[0], 1),
                            u->GetComponent(pts[0], 2));
    const Eigen::Vector3d b(u->GetComponent(pts[1], 0), u->GetComponent(pts[1], 1),
                            u->GetComponent(pts[1], 2));
    const Eigen::Vector3d mid(u->GetComponent(pts[4], 0), u->GetComponent(pts[4], 1),
                              u->GetComponent(pts[4], 2));
    worst_linear = std::max(worst_linear, (mid - 0.5 * (a + b)).norm());
  }
  ASSERT_GT(largest, 1e-3);
  EXPECT_LE(worst, 1e-9 * largest);
  EXPECT_GT(worst_linear, 1e-4 * largest);
}

// Truth: the message itself (what it must name); the modulus of the elements is given.
TEST(SolverDecks, MeshOnlyExportsWarnOnNonPositiveModulusNamingTheFix) {
  const auto dir = vim::test::scratch_dir("decks", "nonpositive");
  MeshModel<3> m = oblique_model<3>({{3, 3, 3}});
  for (std::size_t c = 0; c < m.values.size(); c += 3) m.values[c].mean = -1000.0 + static_cast<double>(c);
  nlohmann::json report;
  report["exports"] = write_exports<3>(m, dir, {"inp", "feb"});
  ASSERT_TRUE(report["exports"].contains("warnings"));
  const std::string w = report["exports"]["warnings"][0];
  for (const char* needed : {"<= 0", "--simulate", "material.scale", "material.clamp"})
    EXPECT_NE(w.find(needed), std::string::npos) << needed << " missing in: " << w;
  nlohmann::json fine;
  m.youngs_modulus.assign(m.mesh.n_cells(), 5.0);
  fine["exports"] = write_exports<3>(m, dir, {"inp"});
  EXPECT_FALSE(fine["exports"].contains("warnings"));
}

// Truth: CalculiX again, end to end through the CLI: examples/prostate_deck.yaml (degree 2) on a small
// prostate phantom; CalculiX's solution of mesh.inp must be the displacement of steps/step_0000.vtu at
// every point (vertices and edge midpoints, the same numbering).
TEST(SolverDecks, CliDeckOfTheProstateExampleSolvesLikeStepZero) {
  if (!have_program("ccx")) GTEST_SKIP() << "CalculiX (ccx, Debian package calculix-ccx) is not installed";
  vim::test::TempDir dir("clideck");
  const fs::path image = dir.path / "prostate.mha";
  const auto made =
      vim::test::run_command(VIM_PHANTOM_EXE, "prostate " + vim::test::quote(image.string()) + " --size 24");
  ASSERT_EQ(made.code, 0) << made.err;
  const fs::path out = dir.path / "out";
  const auto run = vim::test::run_pipeline(
      vim::test::quote(image.string()) + " --nodes 300 --max-iterations 4 -q --export inp --simulate " +
      vim::test::quote(std::string(VIM_SOURCE_DIR) + "/examples/prostate_deck.yaml") + " --out " +
      vim::test::quote(out.string()));
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_NE(vim::test::slurp(out / "mesh.inp").find("TYPE=C3D10"), std::string::npos);
  const auto theirs = run_calculix(out);
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((out / "steps" / "step_0000.vtu").string().c_str());
  reader->Update();
  vtkUnstructuredGrid* g = reader->GetOutput();
  ASSERT_EQ(g->GetCellType(0), 24);  // VTK_QUADRATIC_TETRA
  vtkDataArray* u = g->GetPointData()->GetArray("displacement");
  ASSERT_NE(u, nullptr);
  ASSERT_EQ(static_cast<vtkIdType>(theirs.size()), g->GetNumberOfPoints());
  double largest = 0.0, worst = 0.0;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    const Eigen::Vector3d ours(u->GetComponent(i, 0), u->GetComponent(i, 1), u->GetComponent(i, 2));
    largest = std::max(largest, ours.norm());
    worst = std::max(worst, (theirs.at(i + 1) - ours).cwiseAbs().maxCoeff());
  }
  ASSERT_GT(largest, 0.1);
  EXPECT_LE(worst, 1e-6 * largest);
  std::cout << "CLI prostate deck, " << g->GetNumberOfPoints()
            << " nodes: max |Δu| / max |u| = " << worst / largest << '\n';
}

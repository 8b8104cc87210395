// Truth: the tools the exports are for. CalculiX (ccx) solves the exported mesh.inp of a 3D and a 2D
// scenario with P1 and P2 elements, and its nodal displacements must equal our deal.II solution of
// the same scenario (step 0, the state under the boundary conditions) within 1e-6 of the largest
// displacement: C3D4/CPE3 and C3D10/CPE6 with full integration assemble the same stiffness as deal.II's
// P1/P2 with QGaussSimplex, and the loads are exact for constant pressure and traction. Gmsh reads
// mesh.msh and re-saves it; the node, element and physical-group counts it keeps must be those of the
// Kuhn grid counted independently. Python's XML parser checks mesh.feb against febio_spec 4.0's
// required structure. A test skips (GTEST_SKIP) only when the tool is not installed.
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/exports.hpp>
#include <vim/pipeline/simulation.hpp>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

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
  using P = Eigen::Matrix<double, dim, 1>;
  P lo, hi;
  for (int a = 0; a < dim; ++a) lo[a] = -1.0 - 0.5 * a, hi[a] = 2.0 + 1.5 * a;
  MeshModel<dim> m;
  m.mesh = regular_grid_mesh<dim>(lo, hi, nodes);
  for (int a = 0; a < dim; ++a) m.transform.origin[a] = 10.0 + 3.0 * a;
  if constexpr (dim == 3)
    m.transform.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  else
    m.transform.direction = Eigen::Rotation2Dd(0.6).toRotationMatrix();
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
  y += "  - {type: displacement, region: {box_face: " + last + "_max}, value: " +
       (dim == 3 ? std::string("[0.01, -0.02, -0.05]") : std::string("[0.01, -0.03]")) + "}\n";
  y += "  - {type: fixed, region: {box_face: x_min}, components: [y]}\n";
  y += "  - {type: fixed, region: {sphere: {center: " + vec_yaml<dim>(centre) + ", radius: 0.9}}, components: [x]}\n";
  y += "  - {type: pressure, region: {box_face: x_max}, value: 0.3}\n";
  y += std::string("  - {type: traction, region: {box_face: ") + (dim == 3 ? "y_max" : "x_min") + "}, value: " +
       (dim == 3 ? std::string("[0.05, 0.1, 0.2]") : std::string("[0.05, 0.1]")) + "}\n";
  y += "needle: {entry: " + vec_yaml<dim>(tf.to_world(entry_frame)) + ", direction: " + vec_yaml<dim>(axis) +
       ", depth: 1.0, steps: 2, diameter: 0.1}\n";
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
OurSolution<dim> our_solution(NeedleSimulation<dim>& sim, const MeshModel<dim>& m, const SolverDeck<dim>& deck) {
  const fem::Solution<dim> s = sim.model().solve();
  OurSolution<dim> out;
  for (const auto& u : s.vertex_displacement) out.nodes.push_back(m.transform.vector_to_world(u));
  if (deck.degree == 2)
    for (const auto& u : sim.model().edge_midpoint_displacement(deck.edges)) out.nodes.push_back(m.transform.vector_to_world(u));
  for (const auto& u : out.nodes) out.largest = std::max(out.largest, u.norm());
  return out;
}

template <int dim>
void expect_calculix_agrees(unsigned degree, const std::array<int, dim>& nodes) {
  if (!have_program("ccx")) GTEST_SKIP() << "CalculiX (ccx, Debian package calculix-ccx) is not installed";
  const auto dir = vim::test::scratch_dir("decks", "ccx" + std::to_string(dim) + "d_p" + std::to_string(degree));
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
  write_exports<dim>(m, dir, {"inp"}, report, eo);
  const SolverDeck<dim> deck = solver_deck(m, m.youngs_modulus, sc.poisson_ratio, degree, &sc);
  const OurSolution<dim> ours = our_solution(sim, m, deck);
  ASSERT_GT(ours.largest, 1e-3);
  const auto theirs = run_calculix(dir);
  ASSERT_EQ(theirs.size(), deck.nodes.size()) << "CalculiX printed another node count";
  double worst = 0.0;
  for (std::size_t i = 0; i < deck.nodes.size(); ++i) {
    const Eigen::Vector3d& t = theirs.at(static_cast<long>(i) + 1);
    for (int a = 0; a < dim; ++a) worst = std::max(worst, std::abs(t[a] - ours.nodes[i][a]));
    if (dim == 2) EXPECT_NEAR(t[2], 0.0, 1e-12 + 1e-9 * ours.largest);
  }
  EXPECT_LE(worst, 1e-6 * ours.largest) << "largest displacement " << ours.largest;
  RecordProperty("ccx_max_difference_over_largest", fmt(worst / ours.largest));
  std::cout << "CalculiX vs deal.II, " << dim << "D P" << degree << ": " << deck.nodes.size() << " nodes, max |Δu| / max |u| = "
            << worst / ours.largest << '\n';
}

}  // namespace

TEST(SolverDecks, CalculixSolves3DP1DeckLikeDealII) { expect_calculix_agrees<3>(1, {{5, 5, 6}}); }
TEST(SolverDecks, CalculixSolves3DP2DeckLikeDealII) { expect_calculix_agrees<3>(2, {{4, 4, 5}}); }
TEST(SolverDecks, CalculixSolves2DP1DeckLikeDealII) { expect_calculix_agrees<2>(1, {{9, 11}}); }
TEST(SolverDecks, CalculixSolves2DP2DeckLikeDealII) { expect_calculix_agrees<2>(2, {{6, 7}}); }

// Round trips of the mesh exports (exports.hpp) through independent readers: deal.II's GridIn for
// mesh.vtk and mesh.msh, a tag parser for mesh.feb, a small keyword reader for mesh.inp; and the
// oblique/anisotropic coordinates check (a voxel centre lands on the ITK world point in every file).
#include <deal.II/grid/grid_in.h>
#include <deal.II/grid/tria.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/output/exports.hpp>

#include "oblique_grid.hpp"
#include "run_cli.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim;
using namespace vim::pipeline;

namespace {

using vim::test::ScratchDir;
ScratchDir exports_dir(const std::string& name) { return vim::test::scratch_dir("exports", name); }

using vim::test::slurp;

// A Kuhn grid of the box with an oblique transform and one modulus per element.
template <int dim>
MeshModel<dim> grid_model(const std::array<int, dim>& nodes, bool distinct_moduli, bool mirror) {
  MeshModel<dim> m = vim::test::oblique_grid<dim>(nodes);
  if (mirror) m.transform.direction.col(0) *= -1.0;
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    ElementValue v;
    v.mean = 1.0 + 0.01 * static_cast<double>(c);
    v.voxels = 3;
    m.values.push_back(v);
    // Two clusters far apart (so equal-width bins leave many empty) or a few repeated values.
    m.youngs_modulus.push_back(distinct_moduli ? (c % 2 ? 50.0 + 1e-3 * c : 9000.0 + 0.5 * c)
                                               : 1000.0 * (1 + c % 4));
  }
  return m;
}

template <int dim>
dealii::Point<dim> to_dealii(const Eigen::Matrix<double, dim, 1>& p) {
  dealii::Point<dim> q;
  for (int a = 0; a < dim; ++a) q[a] = p[a];
  return q;
}

// Reads mesh.vtk / mesh.msh with deal.II's GridIn.
template <int dim>
void read_with_dealii(const fs::path& path, dealii::Triangulation<dim>& tria) {
  dealii::GridIn<dim> in;
  in.attach_triangulation(tria);
  std::ifstream f(path);
  ASSERT_TRUE(f) << path;
  if (path.extension() == ".vtk")
    in.read_vtk(f);
  else
    in.read_msh(f);
}

template <int dim>
double signed_measure(const std::array<dealii::Point<dim>, dim + 1>& x) {
  Eigen::Matrix<double, dim, dim> m;
  for (int k = 0; k < dim; ++k)
    for (int a = 0; a < dim; ++a) m(a, k) = x[k + 1][a] - x[0][a];
  return m.determinant();
}

// Checks a deal.II triangulation against the world mesh: same vertices (1e-9), every world cell
// present exactly once (by vertex set), material_id == bin, positively oriented in deal.II order.
template <int dim>
void expect_same_mesh(const dealii::Triangulation<dim>& tria, const SimplexMesh<dim>& world,
                      const MaterialBins& bins, bool same_cell_order) {
  const auto& v = tria.get_vertices();
  ASSERT_EQ(v.size(), world.n_points());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int a = 0; a < dim; ++a) ASSERT_NEAR(v[i][a], world.points[i][a], 1e-9) << "vertex " << i;
  ASSERT_EQ(tria.n_active_cells(), world.n_cells());
  std::map<std::vector<unsigned>, std::size_t> index;
  for (std::size_t c = 0; c < world.n_cells(); ++c) {
    std::vector<unsigned> key(world.cells[c].begin(), world.cells[c].end());
    std::sort(key.begin(), key.end());
    index[key] = c;
  }
  std::set<std::size_t> seen;
  std::size_t k = 0;
  for (const auto& cell : tria.active_cell_iterators()) {
    std::vector<unsigned> key;
    std::array<dealii::Point<dim>, dim + 1> x;
    for (unsigned j = 0; j < cell->n_vertices(); ++j) {
      key.push_back(cell->vertex_index(j));
      x[j] = cell->vertex(j);
    }
    ASSERT_EQ(key.size(), std::size_t(dim + 1));
    EXPECT_GT(signed_measure<dim>(x), 0.0);
    std::sort(key.begin(), key.end());
    const auto it = index.find(key);
    ASSERT_NE(it, index.end()) << "deal.II cell with vertices not in the mesh";
    EXPECT_TRUE(seen.insert(it->second).second);
    EXPECT_EQ(cell->material_id(), static_cast<unsigned>(bins.element_material[it->second]));
    if (same_cell_order) {
      EXPECT_EQ(it->second, k);
    }
    ++k;
  }
}

// --- Abaqus reader: *Node, *Element (TYPE, ELSET), *Solid Section, *Material + *Elastic. ---
struct InpModel {
  std::map<long, std::vector<double>> nodes;
  std::map<long, std::vector<long>> elements;
  std::map<long, std::string> element_set, element_type;
  std::map<std::string, std::string> section_material;       // elset -> material
  std::map<std::string, std::pair<double, double>> elastic;  // material -> (E, nu)
  bool heading = false;
};

std::string upper(std::string s) {
  for (auto& ch : s) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return s;
}

std::map<std::string, std::string> keyword_params(const std::string& line) {
  std::map<std::string, std::string> out;
  std::stringstream s(line);
  std::string item;
  std::getline(s, item, ',');  // keyword itself
  while (std::getline(s, item, ',')) {
    const auto eq = item.find('=');
    auto trim = [](std::string t) {
      t.erase(0, t.find_first_not_of(' '));
      t.erase(t.find_last_not_of(' ') + 1);
      return t;
    };
    if (eq != std::string::npos) out[upper(trim(item.substr(0, eq)))] = trim(item.substr(eq + 1));
  }
  return out;
}

std::vector<double> numbers(const std::string& line) {
  std::vector<double> v;
  std::stringstream s(line);
  std::string item;
  while (std::getline(s, item, ','))
    if (item.find_first_not_of(" \t\r") != std::string::npos) v.push_back(std::stod(item));
  return v;
}

InpModel read_inp(const fs::path& path) {
  InpModel m;
  std::ifstream in(path);
  std::string line, mode, elset, type, material, section_elset;
  while (std::getline(in, line)) {
    if (line.rfind("**", 0) == 0 || line.empty()) continue;
    if (line[0] == '*') {
      const std::string key = upper(line.substr(1, line.find(',') - 1));
      const auto p = keyword_params(line);
      mode = key;
      if (key == "HEADING") m.heading = true;
      if (key == "ELEMENT") elset = p.at("ELSET"), type = p.at("TYPE");
      if (key == "SOLID SECTION")
        section_elset = p.at("ELSET"), m.section_material[section_elset] = p.at("MATERIAL");
      if (key == "MATERIAL") material = p.at("NAME");
      continue;
    }
    if (mode == "NODE") {
      auto v = numbers(line);
      m.nodes[static_cast<long>(v[0])] = std::vector<double>(v.begin() + 1, v.end());
    } else if (mode == "ELEMENT") {
      auto v = numbers(line);
      const long id = static_cast<long>(v[0]);
      for (std::size_t k = 1; k < v.size(); ++k) m.elements[id].push_back(static_cast<long>(v[k]));
      m.element_set[id] = elset;
      m.element_type[id] = type;
    } else if (mode == "ELASTIC") {
      auto v = numbers(line);
      m.elastic[material] = {v.at(0), v.at(1)};
    }
  }
  return m;
}

// --- FEBio: well-formedness by a tag stack, then the fields by regular expressions. ---
void expect_well_formed_xml(const std::string& xml) {
  std::vector<std::string> stack;
  std::size_t pos = 0;
  while ((pos = xml.find('<', pos)) != std::string::npos) {
    const std::size_t end = xml.find('>', pos);
    ASSERT_NE(end, std::string::npos);
    const std::string tag = xml.substr(pos + 1, end - pos - 1);
    pos = end + 1;
    if (tag[0] == '?' || tag[0] == '!') continue;
    if (tag.back() == '/') continue;
    const std::string name =
        tag.substr(tag[0] == '/' ? 1 : 0, tag.find_first_of(" /", 1) - (tag[0] == '/' ? 1 : 0));
    if (tag[0] == '/') {
      ASSERT_FALSE(stack.empty()) << "closing </" << name << "> without opening";
      ASSERT_EQ(stack.back(), name);
      stack.pop_back();
    } else {
      stack.push_back(name);
    }
  }
  EXPECT_TRUE(stack.empty());
}

std::map<long, std::vector<double>> xml_values(const std::string& xml, const std::string& tag,
                                               const std::string& attr) {
  std::map<long, std::vector<double>> out;
  const std::regex re("<" + tag + " " + attr + "=\"(\\d+)\">([^<]*)</" + tag + ">");
  for (std::sregex_iterator it(xml.begin(), xml.end(), re), end; it != end; ++it) {
    std::vector<double> v;
    std::stringstream s((*it)[2].str());
    std::string item;
    while (std::getline(s, item, ',')) v.push_back(std::stod(item));
    out[std::stol((*it)[1].str())] = v;
  }
  return out;
}

std::string capture(const std::string& text, const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(pattern))) return "<missing: " + pattern + ">";
  return m[1].str();
}

}  // namespace

TEST(MaterialBins, DistinctValuesAreExactBins) {
  const auto m = grid_model<3>({{3, 3, 3}}, false, false);
  const auto bins = material_bins(m, 255);
  ASSERT_EQ(bins.n_bins(), 4u);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    EXPECT_EQ(bins.element_material[c], static_cast<int>(1 + c % 4));
    EXPECT_EQ(bins.modulus[bins.element_material[c] - 1], m.youngs_modulus[c]);
  }
}

// Moduli that differ by round-off only are one material (a probe saw 1.1999999999999997 and 1.2 in
// separate bins); values 1e-9 apart stay apart.
TEST(MaterialBins, RoundOffDifferencesShareABin) {
  auto m = grid_model<3>({{3, 3, 3}}, false, false);
  const std::vector<double> values = {1.2, 1.1999999999999997, 1.2000000000000002, 1.2 + 1e-9,
                                      3.0, 3.0 * (1 + 4e-16)};
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) m.youngs_modulus[c] = values[c % values.size()];
  const auto bins = material_bins(m, 255);
  ASSERT_EQ(bins.n_bins(), 3u);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    const std::size_t k = c % values.size();
    const int expected = k < 3 ? 1 : k == 3 ? 2 : 3;
    EXPECT_EQ(bins.element_material[c], expected) << values[k];
  }
  EXPECT_NEAR(bins.modulus[0], 1.2, 1e-15);
  EXPECT_EQ(bins.modulus[1], 1.2 + 1e-9);
  EXPECT_NEAR(bins.modulus[2], 3.0, 1e-15);
}

TEST(MaterialBins, ManyValuesUseAtMost255NonEmptyOrderedBins) {
  const auto m = grid_model<3>({{5, 5, 5}}, true, false);  // 384 distinct values in two clusters
  const auto bins = material_bins(m, 255);
  ASSERT_GT(bins.n_bins(), 2u);
  ASSERT_LE(bins.n_bins(), 255u);
  long total = 0;
  for (std::size_t k = 0; k < bins.n_bins(); ++k) {
    EXPECT_GT(bins.count[k], 0);
    total += bins.count[k];
    if (k > 0) {
      EXPECT_GT(bins.lower[k], bins.upper[k - 1]);
    }
    EXPECT_GE(bins.modulus[k], bins.lower[k]);
    EXPECT_LE(bins.modulus[k], bins.upper[k]);
  }
  EXPECT_EQ(total, static_cast<long>(m.mesh.n_cells()));
  const double width = (9000.0 + 0.5 * (m.mesh.n_cells() - 1) - 50.0) / 255.0;
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    const int k = bins.element_material[c] - 1;
    EXPECT_GE(m.youngs_modulus[c], bins.lower[k]);
    EXPECT_LE(m.youngs_modulus[c], bins.upper[k]);
    EXPECT_LE(bins.upper[k] - bins.lower[k], width * (1 + 1e-9));
  }
}

TEST(MaterialBins, FallsBackToElementMeanWithoutModulus) {
  auto m = grid_model<2>({{3, 3}}, false, false);
  m.youngs_modulus.clear();
  const auto bins = material_bins(m, 255);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) EXPECT_EQ(bins.element_modulus[c], m.values[c].mean);
}

TEST(Exports, UnknownFormatIsRejectedBeforeWriting) {
  const auto dir = exports_dir("unknown");
  const auto m = grid_model<3>({{2, 2, 2}}, false, false);
  nlohmann::json report;
  try {
    report["exports"] = write_exports(m, dir, {"vtk", "stl"});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("'stl'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("vtk, feb, msh, inp"), std::string::npos) << msg;
  }
  EXPECT_FALSE(fs::exists(dir / "mesh.vtk"));
  EXPECT_EQ(parse_export_formats("msh, vtk,msh"), (std::vector<std::string>{"msh", "vtk"}));
  EXPECT_EQ(parse_export_formats("all"), export_formats());
  EXPECT_THROW(parse_export_formats("vtk,obj"), std::invalid_argument);
}

TEST(Exports, RoundTrip3D) {
  const auto dir = exports_dir("rt3");
  const auto m = grid_model<3>({{4, 3, 3}}, false, false);
  nlohmann::json report;
  report["exports"] = write_exports(m, dir, export_formats());
  const auto bins = material_bins(m);
  // World truth computed here: origin + D (p - origin).
  SimplexMesh<3> world = m.mesh;
  for (auto& p : world.points) p = m.transform.origin + m.transform.direction * (p - m.transform.origin);

  for (const char* f : {"vtk", "feb", "msh", "inp"})
    EXPECT_TRUE(fs::exists(dir / (std::string("mesh.") + f))) << f;
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  const auto& table = report["exports"]["material_table"];
  ASSERT_EQ(table.size(), 4u);
  EXPECT_EQ(table[2]["id"], 3);
  EXPECT_EQ(table[2]["E"].get<double>(), 3000.0);
  EXPECT_EQ(report["exports"]["element_modulus"].size(), m.mesh.n_cells());

  {
    dealii::Triangulation<3> tria;
    read_with_dealii<3>(dir / "mesh.vtk", tria);
    expect_same_mesh<3>(tria, world, bins, true);
  }
  {
    dealii::Triangulation<3> tria;
    read_with_dealii<3>(dir / "mesh.msh", tria);
    expect_same_mesh<3>(tria, world, bins, false);
    const std::string msh = slurp(dir / "mesh.msh");
    EXPECT_EQ(msh.rfind("$MeshFormat\n4.1 0 8\n$EndMeshFormat", 0), 0u);
    EXPECT_NE(msh.find("3 4 \"material_4\""), std::string::npos);
  }
  {
    const InpModel inp = read_inp(dir / "mesh.inp");
    EXPECT_TRUE(inp.heading);
    ASSERT_EQ(inp.nodes.size(), world.n_points());
    for (std::size_t i = 0; i < world.n_points(); ++i)
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(inp.nodes.at(i + 1).at(a), world.points[i][a], 1e-9);
    ASSERT_EQ(inp.elements.size(), world.n_cells());
    for (std::size_t c = 0; c < world.n_cells(); ++c) {
      const auto& e = inp.elements.at(c + 1);
      ASSERT_EQ(e.size(), 4u);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(e[k], world.cells[c][k] + 1);
      EXPECT_EQ(inp.element_type.at(c + 1), "C3D4");
      const std::string material = inp.section_material.at(inp.element_set.at(c + 1));
      EXPECT_EQ(inp.elastic.at(material).first, m.youngs_modulus[c]);
      EXPECT_EQ(inp.elastic.at(material).second, 0.49);
    }
  }
  {
    const std::string xml = slurp(dir / "mesh.feb");
    expect_well_formed_xml(xml);
    EXPECT_EQ(capture(xml, "<febio_spec version=\"([0-9.]+)\">"), "4.0");
    EXPECT_EQ(capture(xml, "<material id=\"1\" name=\"(\\w+)\" type=\"isotropic elastic\">"), "tissue");
    const std::string map = capture(xml, "<E type=\"map\">(\\w+)</E>");
    const std::string part = capture(xml, "<Elements type=\"tet4\" name=\"(\\w+)\">");
    EXPECT_EQ(capture(xml, "<ElementData type=\"scalar\" name=\"(\\w+)\" elem_set=\"" + part + "\">"), map);
    EXPECT_EQ(capture(xml, "<SolidDomain name=\"" + part + "\" mat=\"(\\w+)\"/>"), "tissue");
    const auto nodes = xml_values(xml, "node", "id");
    const auto elems = xml_values(xml, "elem", "id");
    const auto e_map = xml_values(xml, "e", "lid");
    ASSERT_EQ(nodes.size(), world.n_points());
    for (std::size_t i = 0; i < world.n_points(); ++i)
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(nodes.at(i + 1).at(a), world.points[i][a], 1e-9);
    ASSERT_EQ(elems.size(), world.n_cells());
    ASSERT_EQ(e_map.size(), world.n_cells());
    for (std::size_t c = 0; c < world.n_cells(); ++c) {
      for (int k = 0; k < 4; ++k) EXPECT_EQ(elems.at(c + 1).at(k), world.cells[c][k] + 1);
      EXPECT_EQ(e_map.at(c + 1).at(0), m.youngs_modulus[c]);
    }
  }
}

TEST(Exports, RoundTrip2DAndFebSkipped) {
  const auto dir = exports_dir("rt2");
  const auto m = grid_model<2>({{5, 4}}, false, false);
  nlohmann::json report;
  report["exports"] = write_exports(m, dir, {"vtk", "feb", "msh", "inp"});
  const auto bins = material_bins(m);
  SimplexMesh<2> world = m.mesh;
  for (auto& p : world.points) p = m.transform.origin + m.transform.direction * (p - m.transform.origin);
  EXPECT_FALSE(fs::exists(dir / "mesh.feb"));
  EXPECT_TRUE(report["exports"]["skipped"].contains("feb"));
  {
    dealii::Triangulation<2> tria;
    read_with_dealii<2>(dir / "mesh.vtk", tria);
    expect_same_mesh<2>(tria, world, bins, true);
  }
  {
    dealii::Triangulation<2> tria;
    read_with_dealii<2>(dir / "mesh.msh", tria);
    expect_same_mesh<2>(tria, world, bins, false);
  }
  const InpModel inp = read_inp(dir / "mesh.inp");
  ASSERT_EQ(inp.elements.size(), world.n_cells());
  EXPECT_EQ(inp.element_type.at(1), "CPE3");
  EXPECT_EQ(inp.nodes.at(1).size(), 2u);
}

// A voxel centre known in index space lands on the ITK world point origin + D·diag(spacing)·index in
// every export, with an oblique, mirroring direction and anisotropic spacing.
TEST(Exports, ObliqueAnisotropicVoxelCentreLandsOnWorldPoint) {
  const auto dir = exports_dir("coords");
  const Eigen::Vector3d origin(-12.5, 40.0, 7.25), spacing(0.5, 1.25, 2.0);
  Eigen::Matrix3d D = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -1.0, 0.5).normalized()).toRotationMatrix();
  D.col(2) *= -1.0;                             // det(D) = -1: every cell must be re-oriented in world space
  const std::array<long, 3> idx = {{4, 2, 3}};  // the voxel centre that becomes a mesh node
  // Frame mesh: a Kuhn grid whose node (1,1,1) is that voxel centre.
  Eigen::Vector3d lo, hi;
  for (int a = 0; a < 3; ++a) {
    const double centre = origin[a] + idx[a] * spacing[a];
    lo[a] = centre - 2.0 * spacing[a];
    hi[a] = centre + 4.0 * spacing[a];  // 4 nodes per axis: node 1 at lo + 2 spacing
  }
  MeshModel<3> m;
  m.mesh = regular_grid_mesh<3>(lo, hi, {{4, 4, 4}});
  m.transform.origin = origin;
  m.transform.direction = D;
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    m.values.push_back({1, 1.0, 0.0});
    m.youngs_modulus.push_back(100.0 + c);
  }
  const std::size_t node = 1 + 4 * (1 + 4 * 1);
  Eigen::Vector3d frame_expected;
  for (int a = 0; a < 3; ++a) frame_expected[a] = origin[a] + idx[a] * spacing[a];
  ASSERT_NEAR((m.mesh.points[node] - frame_expected).norm(), 0.0, 1e-12);
  Eigen::Vector3d idx_d(idx[0], idx[1], idx[2]);
  const Eigen::Vector3d world = origin + D * spacing.asDiagonal() * idx_d;

  nlohmann::json report;
  report["exports"] = write_exports(m, dir, export_formats());
  for (const char* ext : {"vtk", "msh"}) {
    dealii::Triangulation<3> tria;
    read_with_dealii<3>(dir / (std::string("mesh.") + ext), tria);
    const auto& v = tria.get_vertices();
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(v.at(node)[a], world[a], 1e-9) << ext;
    for (const auto& cell : tria.active_cell_iterators()) {
      std::array<dealii::Point<3>, 4> x;
      for (unsigned j = 0; j < 4; ++j) x[j] = cell->vertex(j);
      EXPECT_GT(signed_measure<3>(x), 0.0) << ext;
    }
  }
  const InpModel inp = read_inp(dir / "mesh.inp");
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(inp.nodes.at(node + 1).at(a), world[a], 1e-9);
  const auto nodes = xml_values(slurp(dir / "mesh.feb"), "node", "id");
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(nodes.at(node + 1).at(a), world[a], 1e-9);
}

// --labels through the real executable (docs/labels.md). Truth: the label image itself (its voxel counts,
// a slab whose resampled volume is known in closed form), the independent voxel-centre classification of
// tests/support/label_truth.hpp applied to mesh.vtu (every element's label is its majority, the
// misclassified volume per label), and the exports read back by hand (.inp element sets) and by Gmsh
// (.msh physical groups).
#include <gtest/gtest.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vim/pipeline/image/image_io.hpp>

#include "gmsh_view.hpp"
#include "label_truth.hpp"
#include "run_cli.hpp"

namespace vim::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// 16^3 voxels of 1 mm: label 1, label 2 where x ≥ 8 mm, label 3 in a ball of radius 4.5 at (5, 8, 8).
OrientedImage<3> three_label_image() {
  OrientedImage<3> im;
  im.image = Image<3>({{16, 16, 16}}, {{1.0, 1.0, 1.0}}, {{0.5, 0.5, 0.5}}, 1.0f);
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k) {
    const auto p = im.image.point_of(im.image.index_of(k));
    if (p[0] >= 8.0) im.image.data[k] = 2.0f;
    if ((p - Eigen::Vector3d(5.0, 8.0, 8.0)).norm() <= 4.5) im.image.data[k] = 3.0f;
  }
  return im;
}

json read_json(const fs::path& p) { return json::parse(test::slurp(p)); }

// mesh.vtu's points, cells and `label` cell data.
SimplexMesh<3> read_mesh(const fs::path& vtu, std::vector<int>& label) {
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName(vtu.string().c_str());
  r->Update();
  vtkUnstructuredGrid* g = r->GetOutput();
  SimplexMesh<3> m;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double p[3];
    g->GetPoint(i, p);
    m.points.emplace_back(p[0], p[1], p[2]);
  }
  vtkDataArray* l = g->GetCellData()->GetArray("label");
  EXPECT_NE(l, nullptr) << "mesh.vtu has no label cell data";
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
    vtkIdType n;
    const vtkIdType* ids;
    g->GetCellPoints(c, n, ids);
    m.cells.push_back({{static_cast<int>(ids[0]), static_cast<int>(ids[1]), static_cast<int>(ids[2]),
                        static_cast<int>(ids[3])}});
    label.push_back(l ? static_cast<int>(l->GetTuple1(c)) : 0);
  }
  return m;
}

// Element ids of every `*Elset, ELSET=NAME` of an .inp deck.
std::map<std::string, long> inp_element_sets(const fs::path& inp) {
  std::ifstream in(inp);
  std::map<std::string, long> sets;
  std::string line, current;
  while (std::getline(in, line)) {
    if (line.rfind("*", 0) == 0) {
      current.clear();
      const std::string key = "*Elset, ELSET=";
      if (line.rfind(key, 0) == 0) current = line.substr(key.size()), sets[current] = 0;
      continue;
    }
    if (current.empty()) continue;
    std::stringstream s(line);
    std::string id;
    while (std::getline(s, id, ',')) sets[current] += 1;
  }
  return sets;
}

TEST(LabelsCli, AloneFollowsEveryLabelAndExportsPerLabelSets) {
  const test::TempDir dir("labels_alone");
  const OrientedImage<3> im = three_label_image();
  write_image(im, dir / "labels.mha");
  const auto r =
      test::run_pipeline("--labels " + test::quote(dir / "labels.mha") +
                         " --label-modulus 1=10 --label-modulus 2=20 --label-modulus 3=40 --nodes 343 "
                         "--export inp,msh,vtk,feb -q -o " +
                         test::quote(dir / "out"));
  ASSERT_EQ(r.code, 0) << r.err;
  const json report = read_json(dir.path / "out" / "report.json");
  const json& labels = report["mesh"]["labels"];
  ASSERT_EQ(labels.size(), 3u) << report.dump(1);

  std::vector<int> cell_label;
  const SimplexMesh<3> mesh = read_mesh(dir.path / "out" / "mesh.vtu", cell_label);
  const auto owner = test::label_owner(im.image, mesh);
  const auto counts = test::label_counts(im.image, owner, mesh.n_cells());
  const auto majority = test::majority_labels(im.image, mesh, counts);
  auto misclassified = test::misclassified_volume(im.image, owner, cell_label);
  long wrong = 0;
  std::map<int, long> elements;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    wrong += cell_label[c] != majority[c], ++elements[cell_label[c]];
  EXPECT_EQ(wrong, 0) << "elements whose label is not the majority of their voxel centres";
  std::map<int, double> voxels;
  for (float v : im.image.data) voxels[static_cast<int>(v)] += 1.0;
  double volume = 0.0;
  for (const json& l : labels) {
    const int label = l["label"];
    EXPECT_EQ(l["name"], "label_" + std::to_string(label));
    EXPECT_EQ(l["elements"].get<long>(), elements[label]) << label;
    EXPECT_NEAR(l["voxel_volume"].get<double>(), voxels[label], 1e-9) << label;
    EXPECT_NEAR(l["misclassified_volume"].get<double>(), misclassified[label], 1e-9) << label;
    volume += l["volume"].get<double>();
  }
  EXPECT_NEAR(volume, 16.0 * 16.0 * 16.0, 1e-6);
  EXPECT_LT(test::total(misclassified), 0.1 * voxels[3]);

  // .inp: an element set per label with its elements; .vtk: MaterialID is the label.
  const auto sets = inp_element_sets(dir.path / "out" / "mesh.inp");
  for (const auto& [label, n] : elements) {
    const std::string name = "L_label_" + std::to_string(label);
    ASSERT_TRUE(sets.count(name)) << name;
    EXPECT_EQ(sets.at(name), n) << name;
  }
  const std::string vtk = test::slurp(dir.path / "out" / "mesh.vtk");
  const std::string header = "SCALARS MaterialID int 1\nLOOKUP_TABLE default\n";
  const auto at = vtk.find(header);
  ASSERT_NE(at, std::string::npos);
  std::istringstream ids(vtk.substr(at + header.size()));
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    int id = 0;
    ids >> id;
    ASSERT_EQ(id, cell_label[c]) << "cell " << c;
  }
  // .feb: a domain (element block) per label with its elements, and the febio_spec 4.0 structure.
  const std::string feb = test::slurp(dir.path / "out" / "mesh.feb");
  for (const auto& [label, n] : elements) {
    const std::string open = "<Elements type=\"tet4\" name=\"label_" + std::to_string(label) + "\">";
    const auto begin = feb.find(open), end = feb.find("</Elements>", begin);
    ASSERT_NE(begin, std::string::npos) << open;
    long count = 0;
    for (auto at = feb.find("<elem ", begin); at < end; at = feb.find("<elem ", at + 1)) ++count;
    EXPECT_EQ(count, n) << open;
    EXPECT_NE(feb.find("<SolidDomain name=\"label_" + std::to_string(label) + "\""), std::string::npos);
  }
  const std::string check = "/usr/bin/python3 '" + std::string(VIM_SOURCE_DIR) +
                            "/tests/support/feb_structure.py' " + test::quote(dir / "out/mesh.feb");
  EXPECT_EQ(std::system(check.c_str()), 0) << "mesh.feb fails the febio_spec 4.0 structure check";
  if (std::system("command -v gmsh > /dev/null 2>&1") != 0) GTEST_SKIP() << "Gmsh is not installed";
  const auto groups = test::gmsh_view(dir.path / "out" / "mesh.msh").elements_of_group;
  for (const auto& [label, n] : elements) {
    const std::string name = "label_" + std::to_string(label);
    ASSERT_TRUE(groups.count(name)) << name;
    EXPECT_EQ(groups.at(name), n) << name;
  }
}

TEST(LabelsCli, BesideAModulusImageTheLabelsAreResampledIntoItsGrid) {
  // Modulus image 12^3 of 1 mm; label image of 0.5 mm voxels over the same region shifted by 0.25 mm,
  // label 7 where x < 5 mm. Resampled at the modulus voxel centres (x = 0.5 … 11.5) label 7 holds the
  // five columns x < 5: 5·12·12 voxels of 1 mm³.
  const test::TempDir dir("labels_beside");
  OrientedImage<3> modulus;
  modulus.image = Image<3>({{12, 12, 12}}, {{1.0, 1.0, 1.0}}, {{0.5, 0.5, 0.5}}, 15.0f);
  write_image(modulus, dir / "modulus.mha");
  OrientedImage<3> labels;
  labels.image = Image<3>({{24, 24, 24}}, {{0.5, 0.5, 0.5}}, {{0.5, 0.5, 0.5}}, 1.0f);
  for (std::size_t k = 0; k < labels.image.voxel_count(); ++k)
    if (labels.image.point_of(labels.image.index_of(k))[0] < 5.0) labels.image.data[k] = 7.0f;
  write_image(labels, dir / "labels.mha");
  const auto r =
      test::run_pipeline(test::quote(dir / "modulus.mha") + " --labels " + test::quote(dir / "labels.mha") +
                         " --nodes 125 --export none -q -o " + test::quote(dir / "out"));
  ASSERT_EQ(r.code, 0) << r.err;
  const json report = read_json(dir.path / "out" / "report.json");
  const json& l = report["mesh"]["labels"];
  ASSERT_EQ(l.size(), 2u);
  EXPECT_EQ(l[1]["label"], 7);
  EXPECT_NEAR(l[1]["voxel_volume"].get<double>(), 5.0 * 12 * 12, 1e-9);
  EXPECT_NEAR(l[0]["voxel_volume"].get<double>(), 7.0 * 12 * 12, 1e-9);
}

// A column of two labels (x < 8 mm: E1 = 10, beyond: E2 = 40 from the scenario's label table, beside a
// modulus image of 15 everywhere; 16×8×8 voxels of 1 mm) on the grid mesher, whose node planes x = 0, 2, …,
// 16 hold the interface, compressed by δ along x with ν = 0 and rollers on x_min, y_min, z_min. Truth: the
// layered solution, one stress σ = δ / (8/E1 + 8/E2) and u_x = σ x/E1 below the interface, σ·8/E1 + σ(x −
// 8)/E2 above, u_y = u_z = 0, for our solve and for CalculiX on mesh.inp (a material per label); and the
// deck's node set of a label region is the nodes whose nearest voxel holds that label.
TEST(LabelsCli, TwoLabelColumnUnderCompressionMatchesTheLayeredSolution) {
  const test::TempDir dir("labels_column");
  OrientedImage<3> im;
  im.image = Image<3>({{16, 8, 8}}, {{1.0, 1.0, 1.0}}, {{0.5, 0.5, 0.5}}, 1.0f);
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k)
    if (im.image.index_of(k)[0] >= 8) im.image.data[k] = 2.0f;
  write_image(im, dir / "column.mha");
  OrientedImage<3> modulus = im;  // a constant modulus image: the label table alone makes the layers
  std::fill(modulus.image.data.begin(), modulus.image.data.end(), 15.0f);
  write_image(modulus, dir / "modulus.mha");
  const double delta = 0.16;
  std::ofstream(dir / "column.yaml")
      << "material: {poisson_ratio: 0.0}\n"
      << "labels:\n  1: {name: soft, youngs_modulus: 10}\n  2: {name: stiff, youngs_modulus: 40}\n"
      << "boundary_conditions:\n"
      << "  - {type: fixed, region: {box_face: x_min}, components: [x]}\n"
      << "  - {type: fixed, region: {box_face: y_min}, components: [y]}\n"
      << "  - {type: fixed, region: {box_face: z_min}, components: [z]}\n"
      << "  - {type: displacement, region: {box_face: x_max}, value: [" << -delta
      << ", 0, 0], components: [x]}\n"
      << "  - {type: fixed, region: {label: stiff}, components: [y]}\n";
  const auto r =
      test::run_pipeline(test::quote(dir / "modulus.mha") + " --labels " + test::quote(dir / "column.mha") +
                         " --mesher grid --nodes 225 --simulate " + test::quote(dir / "column.yaml") +
                         " --export inp -q -o " + test::quote(dir / "out"));
  ASSERT_EQ(r.code, 0) << r.err;
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((dir.path / "out" / "steps" / "step_0000.vtu").string().c_str());
  reader->Update();
  vtkUnstructuredGrid* g = reader->GetOutput();
  vtkDataArray* u = g->GetPointData()->GetArray("displacement");
  ASSERT_NE(u, nullptr);
  const double sigma = -delta / (8.0 / 10.0 + 8.0 / 40.0);
  double worst = 0.0;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double p[3];
    g->GetPoint(i, p);
    const double ux = p[0] <= 8.0 ? sigma * p[0] / 10.0 : sigma * 8.0 / 10.0 + sigma * (p[0] - 8.0) / 40.0;
    worst = std::max({worst, std::abs(u->GetComponent(i, 0) - ux), std::abs(u->GetComponent(i, 1)),
                      std::abs(u->GetComponent(i, 2))});
  }
  EXPECT_LT(worst, 1e-8 * delta);
  // The label region's node set (BC5, 1-based ids of mesh.vtu's points).
  std::ifstream inp(dir.path / "out" / "mesh.inp");
  std::string line;
  std::vector<long> in_set;
  bool reading = false;
  while (std::getline(inp, line)) {
    if (line.rfind("*", 0) == 0) {
      reading = line == "*Nset, NSET=N_BC5_fixed";
      continue;
    }
    if (!reading) continue;
    std::stringstream ids(line);
    std::string id;
    while (std::getline(ids, id, ',')) in_set.push_back(std::stol(id) - 1);
  }
  std::vector<long> truth;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double p[3];
    g->GetPoint(i, p);
    const long ix = std::lround(std::clamp(p[0] - 0.5, 0.0, 15.0));  // nearest voxel along x
    if (ix >= 8) truth.push_back(static_cast<long>(i));
  }
  std::sort(in_set.begin(), in_set.end());
  EXPECT_EQ(in_set, truth);
  // CalculiX runs mesh.inp, a material per label, as written: its displacements are the layered solution.
  if (std::system("command -v ccx > /dev/null 2>&1") != 0) GTEST_SKIP() << "CalculiX (ccx) is not installed";
  const fs::path out = dir.path / "out";
  ASSERT_EQ(std::system(("cd " + test::quote(out.string()) + " && ccx -i mesh > ccx.log 2>&1").c_str()), 0);
  std::ifstream dat(out / "mesh.dat");
  bool block = false;
  long nodes = 0;
  double worst_ccx = 0.0;
  while (std::getline(dat, line)) {
    if (line.find("displacements") != std::string::npos) {
      block = true;
      continue;
    }
    std::istringstream row(line);
    long node;
    double v[3];
    if (!block || !(row >> node >> v[0] >> v[1] >> v[2])) continue;
    double p[3];
    g->GetPoint(node - 1, p);
    const double ux = p[0] <= 8.0 ? sigma * p[0] / 10.0 : sigma * 8.0 / 10.0 + sigma * (p[0] - 8.0) / 40.0;
    worst_ccx = std::max({worst_ccx, std::abs(v[0] - ux), std::abs(v[1]), std::abs(v[2])});
    ++nodes;
  }
  EXPECT_EQ(nodes, g->GetNumberOfPoints());
  EXPECT_LT(worst_ccx, 1e-6 * delta);  // mesh.dat prints 7 significant digits
}

// The label errors: one line naming the file, voxel, label or key.
TEST(LabelsCli, BadLabelInputsAreOneLineErrors) {
  const test::TempDir dir("labels_errors");
  const OrientedImage<3> im = three_label_image();
  write_image(im, dir / "labels.mha");
  OrientedImage<3> fractional = im;
  fractional.image.at({{3, 4, 5}}) = 1.5f;
  write_image(fractional, dir / "fractional.mha");
  OrientedImage<3> far = im;
  far.image.origin = {{100.5, 0.5, 0.5}};
  write_image(far, dir / "far.mha");
  OrientedImage<3> modulus = im;
  write_image(modulus, dir / "modulus.mha");
  {
    std::ofstream(dir / "s.yaml")
        << "labels:\n  1: {name: gland, youngs_modulus: 10}\n  9: {name: lesion}\n"
        << "boundary_conditions:\n  - {type: fixed, region: {box_face: x_min}}\n"
        << "  - {type: displacement, region: {box_face: x_max}, value: [0.1, 0, 0]}\n";
  }
  const std::string all = " --label-modulus 1=10 --label-modulus 2=20 --label-modulus 3=40";
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {"--labels " + test::quote(dir / "fractional.mha") + all,
       "voxel (3,4,5) holds 1.5, not an integer label"},
      {"--labels " + test::quote(dir / "labels.mha") + " --label-modulus 1=10 --label-modulus 2=20",
       "label 3 (label_3) has no Young's modulus"},
      {"--labels " + test::quote(dir / "labels.mha") + all + " --simulate " + test::quote(dir / "s.yaml"),
       "labels: label 9 (lesion) is not in"},
      {test::quote(dir / "modulus.mha") + " --labels " + test::quote(dir / "far.mha"),
       "the label image does not overlap the modulus image"},
      {"--labels " + test::quote(dir / "labels.mha") + " --label-modulus 1=ten", "--label-modulus 1=ten"},
      // The voxel model takes labels beside IMAGE for regions and targets, its moduli from IMAGE alone.
      {"--labels " + test::quote(dir / "labels.mha") + all + " --mesher voxel",
       "give IMAGE beside the labels"},
      {test::quote(dir / "modulus.mha") + " --labels " + test::quote(dir / "labels.mha") +
           " --label-modulus 2=20 --mesher voxel",
       "label 2 has a Young's modulus of its own, but the voxel model"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const auto r = test::run_pipeline(c.args + " -o " + test::quote(dir / ("out" + std::to_string(k++))));
    EXPECT_EQ(r.code, 1) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_EQ(test::count_lines(r.err), 1) << r.err;
  }
}

}  // namespace
}  // namespace vim::pipeline

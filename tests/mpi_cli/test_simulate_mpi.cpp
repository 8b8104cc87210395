// One simulation on two MPI ranks through the real CLI (this program starts `mpirun -np 2 vim-pipeline
// ...`). Truth: the serial run of the same image and scenario (CHOLMOD's direct solve, one process);
// the two-rank run (CG + AMG on the distributed mesh, the needle's compliance columns one distributed
// solve each) gives the same needle forces, target displacements, step displacements and stresses to
// 1e-8 of their scale, with the steps as .pvtu files of one piece per rank.
#include <gtest/gtest.h>
#include <vtkCell.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "run_cli.hpp"
#include "run_on_ranks.hpp"
#include "study_inputs.hpp"

using vim::test::quote;
using vim::test::run_command;
using vim::test::run_on_ranks;
using vim::test::run_pipeline;
namespace fs = std::filesystem;

namespace {

template <class Reader>
vtkSmartPointer<vtkUnstructuredGrid> read_grid(const fs::path& path) {
  vtkNew<Reader> r;
  r->SetFileName(path.c_str());
  r->Update();
  return r->GetOutput();
}

// A point field of a grid by the point's coordinates (pieces renumber and repeat their shared points).
using PointValues = std::map<std::array<double, 3>, std::vector<double>>;
PointValues by_position(vtkUnstructuredGrid* g, const char* field) {
  PointValues out;
  vtkDataArray* a = g->GetPointData()->GetArray(field);
  if (!a) return out;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    std::array<double, 3> p{};
    g->GetPoint(i, p.data());
    std::vector<double> v(static_cast<std::size_t>(a->GetNumberOfComponents()));
    for (int c = 0; c < a->GetNumberOfComponents(); ++c)
      v[static_cast<std::size_t>(c)] = a->GetComponent(i, c);
    out[p] = v;
  }
  return out;
}

// The largest |a − b| over all entries and the largest |a|.
struct Misfit {
  double diff = 0.0, scale = 0.0;
  void add(double a, double b) {
    diff = std::max(diff, std::abs(a - b));
    scale = std::max(scale, std::abs(a));
  }
};

// A cell by the sorted coordinates of its points (pieces renumber their points and hold the cells in
// their rank's order), and its cell fields.
using CellKey = std::vector<std::array<double, 3>>;
std::map<CellKey, std::vector<double>> by_cell(vtkUnstructuredGrid* g) {
  std::map<CellKey, std::vector<double>> out;
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
    vtkIdList* ids = g->GetCell(c)->GetPointIds();
    CellKey key(static_cast<std::size_t>(ids->GetNumberOfIds()));
    for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k)
      g->GetPoint(ids->GetId(k), key[static_cast<std::size_t>(k)].data());
    std::sort(key.begin(), key.end());
    std::vector<double> values;
    for (int a = 0; a < g->GetCellData()->GetNumberOfArrays(); ++a) {
      vtkDataArray* f = g->GetCellData()->GetArray(a);
      for (int k = 0; k < f->GetNumberOfComponents(); ++k) values.push_back(f->GetComponent(c, k));
    }
    out[key] = values;
  }
  return out;
}

// The pieces a .pvtu names (its Piece Source attributes).
std::vector<std::string> piece_sources(const fs::path& pvtu) {
  std::ifstream in(pvtu);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::string> out;
  const std::string tag = "<Piece Source=\"";
  for (std::size_t at = text.find(tag); at != std::string::npos; at = text.find(tag, at + 1)) {
    const std::size_t from = at + tag.size();
    out.push_back(text.substr(from, text.find('"', from) - from));
  }
  return out;
}

// Step `step` of the serial run (.vtu) against the two-rank run (.pvtu naming one piece per rank, each
// written by its rank: the cells it owns): the pieces together hold every serial cell once (matched by
// its points' coordinates) and no other, each piece a non-empty part; the displacement at every point
// and every cell field (stress, von Mises, ...) agree.
void expect_same_step(const fs::path& serial, const fs::path& two, const std::string& step) {
  const auto a = read_grid<vtkXMLUnstructuredGridReader>(serial / "steps" / (step + ".vtu"));
  ASSERT_TRUE(fs::exists(two / "steps" / (step + ".pvtu")));
  EXPECT_EQ(piece_sources(two / "steps" / (step + ".pvtu")),
            (std::vector<std::string>{step + "_0.vtu", step + "_1.vtu"}));
  vtkIdType piece_cells = 0;
  for (const std::string r : {"_0", "_1"}) {
    const auto piece = read_grid<vtkXMLUnstructuredGridReader>(two / "steps" / (step + r + ".vtu"));
    EXPECT_GT(piece->GetNumberOfCells(), 0) << step << r;
    EXPECT_LT(piece->GetNumberOfCells(), a->GetNumberOfCells()) << step << r;
    piece_cells += piece->GetNumberOfCells();
  }
  EXPECT_EQ(piece_cells, a->GetNumberOfCells());
  const auto b = read_grid<vtkXMLPUnstructuredGridReader>(two / "steps" / (step + ".pvtu"));
  ASSERT_EQ(a->GetNumberOfCells(), b->GetNumberOfCells());
  const PointValues ua = by_position(a, "displacement"), ub = by_position(b, "displacement");
  ASSERT_FALSE(ua.empty());
  ASSERT_EQ(ua.size(), ub.size());
  Misfit u;
  for (const auto& [p, v] : ua) {
    ASSERT_EQ(ub.count(p), 1u);
    for (std::size_t c = 0; c < v.size(); ++c) u.add(v[c], ub.at(p)[c]);
  }
  EXPECT_GT(u.scale, 0.0);
  EXPECT_LE(u.diff, 1e-8 * u.scale) << step << " displacement";
  ASSERT_TRUE(a->GetCellData()->GetArray("stress") && b->GetCellData()->GetArray("stress"));
  const auto ca = by_cell(a), cb = by_cell(b);
  ASSERT_EQ(ca.size(), static_cast<std::size_t>(a->GetNumberOfCells()));  // no two cells alike
  ASSERT_EQ(cb.size(), ca.size());                                        // every cell once
  Misfit s;
  for (const auto& [key, values] : ca) {
    ASSERT_EQ(cb.count(key), 1u) << step << ": a serial cell is in no piece";
    ASSERT_EQ(cb.at(key).size(), values.size());
    for (std::size_t k = 0; k < values.size(); ++k) s.add(values[k], cb.at(key)[k]);
  }
  EXPECT_GT(s.scale, 0.0);
  EXPECT_LE(s.diff, 1e-8 * s.scale) << step << " cell fields";
}

// needle.csv as columns of numbers.
std::map<std::string, std::vector<double>> read_columns(const fs::path& path) {
  std::map<std::string, std::vector<double>> out;
  for (const auto& row : vim::test::read_study_csv(path))
    for (const auto& [column, cell] : row) out[column].push_back(cell.empty() ? 0.0 : std::stod(cell));
  return out;
}

nlohmann::json read_json(const fs::path& path) { return nlohmann::json::parse(std::ifstream(path)); }

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = 0; (at = text.find(what, at)) != std::string::npos; ++at) ++n;
  return n;
}

}  // namespace

// A needle (finite diameter: the band rows with their series compliance) into the table1 phantom, on a
// VIM mesh (fully distributed triangulation) and on the voxel model (p4est): every column of needle.csv
// (forces, tip, target displacements) and the last step agree, the VIM mesh solved by MUMPS and the voxel
// model by CG + AMG, and rank 0's model is smaller than the serial one (no serial mesh or stiffness
// matrix on the ranks).
TEST(SimulateMpi, NeedleOnTwoRanksEqualsTheSerialRun) {
  vim::test::TempDir dir("simulate_mpi_needle");
  vim::test::write_study_inputs(dir.path);
  std::ofstream(dir.path / "base.yaml", std::ios::app) << "solver: {tolerance: 1e-13}\n";
  for (const std::string mesher : {"vim", "voxel"}) {
    const fs::path serial_dir = dir.path / ("serial_" + mesher), two_dir = dir.path / ("two_" + mesher);
    const std::string common = quote(dir / "in.mha") + " --mesher " + mesher +
                               " --nodes 100 --max-iterations 3 --export none --simulate " +
                               quote(dir / "base.yaml") + " --out ";
    const auto serial = run_pipeline(common + quote(serial_dir.string()) + " -q");
    ASSERT_EQ(serial.code, 0) << serial.err;
    const auto two = run_on_ranks(2, common + quote(two_dir.string()));
    ASSERT_EQ(two.code, 0) << two.err;
    const auto a = read_columns(serial_dir / "needle.csv");
    const auto b = read_columns(two_dir / "needle.csv");
    ASSERT_EQ(a.size(), b.size());
    ASSERT_TRUE(a.count("axial_force"));
    // A column that is zero by symmetry (lateral force, a target's off-axis displacement) holds
    // rounding noise: its scale is at least 1e-6 of the largest number of the file.
    double file_scale = 0.0;
    for (const auto& [column, values] : a)
      for (const double v : values) file_scale = std::max(file_scale, std::abs(v));
    for (const auto& [column, values] : a) {
      ASSERT_EQ(values.size(), b.at(column).size()) << column;
      Misfit m;
      for (std::size_t i = 0; i < values.size(); ++i) m.add(values[i], b.at(column)[i]);
      EXPECT_LE(m.diff, 1e-8 * std::max(m.scale, 1e-6 * file_scale)) << mesher << " " << column;
    }
    EXPECT_GT(std::abs(a.at("axial_force").back()), 0.0);
    expect_same_step(serial_dir, two_dir, "step_0003");
    int pvtu = 0;  // every step's .pvtu names pieces that are all there
    for (const auto& f : fs::directory_iterator(two_dir / "steps"))
      if (f.path().extension() == ".pvtu") {
        ++pvtu;
        for (const auto& piece : piece_sources(f.path()))
          EXPECT_TRUE(fs::exists(two_dir / "steps" / piece)) << piece;
      }
    EXPECT_EQ(pvtu, 2) << mesher;  // steps 0 and 3 (output every 3)
    const auto report = read_json(two_dir / "report.json");
    EXPECT_NE(report.dump().find("mpi, 2 ranks"), std::string::npos) << mesher;
    // solver.type auto: the VIM mesh factorised once by MUMPS (its estimate fits the memory), the voxel
    // model by CG + AMG
    const auto solver = report["simulation"]["needles"][0]["solver"];
    EXPECT_EQ(solver["method"], mesher == "vim" ? "mumps (mpi, 2 ranks)" : "cg+amg (mpi, 2 ranks)");
    EXPECT_NE(solver.value("reason", "").find(mesher == "vim" ? "MUMPS estimates" : "voxel model"),
              std::string::npos)
        << solver.dump();
    // rank 0 holds no serial stiffness matrix (the serial run holds K and K_full) ...
    const double two_bytes = report["simulation"]["model"]["memory_bytes"];
    const double serial_bytes = read_json(serial_dir / "report.json")["simulation"]["model"]["memory_bytes"];
    std::cout << mesher << ": model bytes serial " << serial_bytes << ", rank 0 of 2 " << two_bytes << "\n";
    EXPECT_LT(two_bytes, 0.8 * serial_bytes) << mesher;
    // and only its part of the mesh, owned and ghost cells (on this small mesh the ghost layer is a
    // good share of it), never the whole serial mesh on top
    const double two_cells = report["simulation"]["model"]["cells_held"];
    const double serial_cells = read_json(serial_dir / "report.json")["simulation"]["model"]["cells_held"];
    std::cout << mesher << ": cells held serial " << serial_cells << ", rank 0 of 2 " << two_cells << "\n";
    EXPECT_GT(two_cells, 0) << mesher;
    EXPECT_LT(two_cells, serial_cells) << mesher;
    EXPECT_TRUE(fs::exists(two_dir / "mesh.vtu"));
    EXPECT_FALSE(fs::exists(two_dir / "steps" / "step_0003.vtu"));
  }
}

// A compression of the voxel model (p4est on two ranks, no serial mesh): the step's displacements and
// stresses and the sampled target agree.
TEST(SimulateMpi, VoxelCompressionOnTwoRanksEqualsTheSerialRun) {
  vim::test::TempDir dir("simulate_mpi_voxel");
  vim::test::write_study_inputs(dir.path);
  std::ofstream(dir.path / "press.yaml")
      << "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
         "boundary_conditions:\n"
         "  - {type: fixed, region: {box_face: z_min}}\n"
         "  - {type: displacement, region: {box_face: z_max}, value: [0.02, 0, -0.05]}\n"
         "targets: [{name: inner, position: [1.3, 1.7, 2.2]}]\n"
         "solver: {tolerance: 1e-13}\n";
  const std::string common =
      quote(dir / "in.mha") + " --mesher voxel --simulate " + quote(dir / "press.yaml") + " --out ";
  const auto serial = run_pipeline(common + quote(dir / "serial") + " -q");
  ASSERT_EQ(serial.code, 0) << serial.err;
  const auto two = run_on_ranks(2, common + quote(dir / "two"));
  ASSERT_EQ(two.code, 0) << two.err;
  expect_same_step(dir.path / "serial", dir.path / "two", "step_0000");
  const auto ta =
      read_json(dir.path / "serial" / "report.json")["simulation"]["static_load"]["targets"]["inner"];
  const auto tb =
      read_json(dir.path / "two" / "report.json")["simulation"]["static_load"]["targets"]["inner"];
  Misfit m;
  for (int c = 0; c < 3; ++c) m.add(ta["displacement"][c].get<double>(), tb["displacement"][c].get<double>());
  EXPECT_GT(m.scale, 1e-4);
  EXPECT_LE(m.diff, 1e-8 * m.scale);
}

// A bad scenario on two ranks: one error line, a non-zero exit, no output folder.
TEST(SimulateMpi, AnErrorIsPrintedOnceAndEveryRankFails) {
  vim::test::TempDir dir("simulate_mpi_error");
  vim::test::write_study_inputs(dir.path);
  std::ofstream(dir.path / "bad.yaml") << "material: {youngs_modulus: image, poisson_ratio: 0.7}\n";
  const auto two = run_on_ranks(2, quote(dir / "in.mha") + " --mesher voxel --simulate " +
                                       quote(dir / "bad.yaml") + " --out " + quote(dir / "out"));
  EXPECT_NE(two.code, 0);
  EXPECT_EQ(count(two.err, "vim-pipeline: error:"), 1u) << two.err;
  EXPECT_NE(two.err.find("poisson_ratio"), std::string::npos) << two.err;
  EXPECT_FALSE(fs::exists(dir.path / "out" / "report.json"));
}

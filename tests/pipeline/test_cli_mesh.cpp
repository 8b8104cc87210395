// The vim-pipeline CLI in mesh-only mode, run as a separate process on small 2D and 3D phantoms
// with anisotropic spacing and an oblique direction: mesh.vtu read back with VTK (world
// coordinates, cell data, conservation of voxels and of the image's integral), report.json fields,
// usage errors (exit 2), refusal of a non-empty --out, --help/--version/--info.
#include <gtest/gtest.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/vim.hpp>

#include "cli_in_process.hpp"
#include "mesh_angles.hpp"
#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;
using vim::test::quote;
using vim::test::run_pipeline;

namespace {

Eigen::Matrix3d rotation3() {
  const Eigen::Vector3d k = Eigen::Vector3d(2, -1, 1).normalized();
  Eigen::Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return Eigen::Matrix3d::Identity() + std::sin(0.5) * K + (1 - std::cos(0.5)) * K * K;
}

vtkSmartPointer<vtkUnstructuredGrid> read_vtu(const std::string& path) {
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName(path.c_str());
  r->Update();
  vtkSmartPointer<vtkUnstructuredGrid> g = r->GetOutput();
  return g;
}

// World position of continuous index `idx` (voxel centres at integers), computed from the
// definition world = origin + D·(idx ⊙ spacing), independently of the pipeline's transform code.
template <int dim>
Eigen::Matrix<double, dim, 1> world_of_index(const OrientedImage<dim>& im,
                                             const Eigen::Matrix<double, dim, 1>& idx) {
  Eigen::Matrix<double, dim, 1> o, s;
  for (int a = 0; a < dim; ++a) o[a] = im.image.origin[a], s[a] = im.image.spacing[a];
  return o + im.direction * idx.cwiseProduct(s);
}

// Signed measure of cell c from its world points: a simplex's (times dim!), a quad's or hexahedron's
// from its corners 0, 1, 3 (and 4), the edges from corner 0 in VTK's corner order. VTK (ParaView's
// Cell Size, Mesh Quality) takes positive cells: positive here.
double signed_cell_measure(vtkUnstructuredGrid* g, vtkIdType c, int dim) {
  vtkNew<vtkIdList> ids;
  g->GetCellPoints(c, ids);
  const int type = g->GetCellType(c);
  const bool lattice = type == 9 || type == 12;
  const int corners[3] = {1, lattice ? 3 : 2, lattice ? 4 : 3};
  double p0[3];
  g->GetPoint(ids->GetId(0), p0);
  Eigen::Matrix3d e = Eigen::Matrix3d::Identity();
  for (int k = 0; k < dim; ++k) {
    double q[3];
    g->GetPoint(ids->GetId(corners[k]), q);
    for (int a = 0; a < 3; ++a) e(a, k) = q[a] - p0[a];
  }
  return dim == 3 ? e.determinant() : e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0);
}

template <int dim>
long count_non_positive_cells(vtkUnstructuredGrid* g) {
  long bad = 0;
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) bad += !(signed_cell_measure(g, c, dim) > 0.0);
  return bad;
}

// Checks shared by the 2D and 3D runs.
template <int dim>
void check_mesh_output(const OrientedImage<dim>& im, const std::filesystem::path& out, bool with_segments) {
  auto g = read_vtu((out / "mesh.vtu").string());
  ASSERT_GT(g->GetNumberOfCells(), 0);
  EXPECT_EQ(g->GetCellType(0), dim == 3 ? 10 : 5);
  EXPECT_EQ(count_non_positive_cells<dim>(g), 0) << "cells inside out in world coordinates";

  // Every corner of the voxel box (continuous index −½ or size−½) is a mesh node in world
  // coordinates (corners are fixed), and every node maps back inside the box.
  for (int corner = 0; corner < (1 << dim); ++corner) {
    Eigen::Matrix<double, dim, 1> idx;
    for (int a = 0; a < dim; ++a) idx[a] = (corner >> a) & 1 ? im.image.size[a] - 0.5 : -0.5;
    const auto w = world_of_index(im, idx);
    double best = 1e30;
    for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
      double p[3];
      g->GetPoint(i, p);
      double d2 = 0;
      for (int a = 0; a < dim; ++a) d2 += (p[a] - w[a]) * (p[a] - w[a]);
      best = std::min(best, d2);
    }
    EXPECT_LT(std::sqrt(best), 1e-9) << "corner " << corner << " not found in world coordinates";
  }
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double p[3];
    g->GetPoint(i, p);
    Eigen::Matrix<double, dim, 1> w, o;
    for (int a = 0; a < dim; ++a) w[a] = p[a], o[a] = im.image.origin[a];
    const Eigen::Matrix<double, dim, 1> frame = im.direction.transpose() * (w - o);
    for (int a = 0; a < dim; ++a) {
      const double c = frame[a] / im.image.spacing[a];
      EXPECT_GE(c, -0.5 - 1e-9);
      EXPECT_LE(c, im.image.size[a] - 0.5 + 1e-9);
    }
    if (dim == 2) {
      EXPECT_EQ(p[2], 0.0);
    }
  }

  // Cell data: every voxel centre in exactly one element, and Σ n·mean = Σ voxel values.
  vtkDataArray* mean = g->GetCellData()->GetArray("mean");
  vtkDataArray* var = g->GetCellData()->GetArray("variance");
  vtkDataArray* vox = g->GetCellData()->GetArray("voxels");
  vtkDataArray* quality = g->GetCellData()->GetArray("quality");
  ASSERT_TRUE(mean && var && vox && quality);
  ASSERT_NE(g->GetPointData()->GetArray("boundary"), nullptr);
  double n = 0, integral = 0;
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
    n += vox->GetTuple1(c);
    integral += vox->GetTuple1(c) * mean->GetTuple1(c);
    EXPECT_GE(var->GetTuple1(c), 0.0);
    if (dim == 3)
      EXPECT_LE(quality->GetTuple1(c), 150.0 + 1e-9);
    else
      EXPECT_GT(quality->GetTuple1(c), 0.0);
  }
  double total = 0;
  for (float v : im.image.data) total += v;
  EXPECT_EQ(n, static_cast<double>(im.image.voxel_count()));
  EXPECT_NEAR(integral, total, 1e-6 * std::abs(total));
  if (with_segments) {
    vtkDataArray* seg = g->GetCellData()->GetArray("segment");
    vtkDataArray* obj = g->GetCellData()->GetArray("object");
    ASSERT_TRUE(seg && obj);
    long in_object = 0;
    for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) in_object += obj->GetTuple1(c) == 1.0;
    EXPECT_GT(in_object, 0);
  }

  // report.json
  const auto report = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
  EXPECT_FALSE(report["tool"]["version"].get<std::string>().empty());
  EXPECT_TRUE(report["command_line"].is_array());
  EXPECT_EQ(report["input"]["dimension"].get<int>(), dim);
  for (int a = 0; a < dim; ++a) {
    EXPECT_EQ(report["input"]["size"][a].get<long>(), im.image.size[a]);
    EXPECT_DOUBLE_EQ(report["input"]["spacing"][a].get<double>(), im.image.spacing[a]);
    EXPECT_DOUBLE_EQ(report["input"]["origin"][a].get<double>(), im.image.origin[a]);
    for (int b = 0; b < dim; ++b)
      EXPECT_NEAR(report["input"]["direction"][a * dim + b].get<double>(), im.direction(a, b), 1e-12);
  }
  // The voxel box's centre in world coordinates: the centre of the middle voxel index (size − 1)/2.
  Eigen::Matrix<double, dim, 1> mid;
  for (int a = 0; a < dim; ++a) mid[a] = 0.5 * static_cast<double>(im.image.size[a] - 1);
  const Eigen::Matrix<double, dim, 1> centre = world_of_index(im, mid);
  for (int a = 0; a < dim; ++a)
    EXPECT_NEAR(report["input"]["world_centre"][a].get<double>(), centre[a], 1e-9) << "axis " << a;
  EXPECT_EQ(report["mesh"]["nodes"].get<long>(), g->GetNumberOfPoints());
  EXPECT_EQ(report["mesh"]["elements"].get<long>(), g->GetNumberOfCells());
  EXPECT_TRUE(report["mesh"]["quality"].contains("max_dihedral_deg"));
  EXPECT_TRUE(report["mesh"]["quality"].contains("min_nrr"));
  EXPECT_EQ(report["mesh"]["quality"]["inverted"].get<long>(), 0);
  EXPECT_TRUE(report["options"].contains("lambda"));
  const auto& h = report["optimization"]["history"];
  ASSERT_GE(h.size(), 1u);
  for (const char* k : {"E", "E_G", "E_D", "v", "moves", "evaluations", "swaps"})
    EXPECT_TRUE(h[0].contains(k)) << k;
  if (h.size() > 1) {
    EXPECT_GT(h[1]["evaluations"].get<long>(), 0);  // iteration 1 searched every node
  }
  EXPECT_EQ(report["options"]["search_width"].get<int>(), vim::VimOptions{}.search_width);
  EXPECT_TRUE(report["optimization"].contains("converged"));
  EXPECT_TRUE(report["timing"].contains("read_image"));
  EXPECT_TRUE(report["timing"].contains("total"));
  if (with_segments) {
    EXPECT_GT(report["segmentation"]["object_elements"].get<long>(), 0);
  }
}

}  // namespace

TEST(CliMesh, TwoDimensionalObliqueAnisotropic) {
  vim::test::TempDir dir("cli2");
  auto im = phantoms::two_inclusions(40);
  im.image.spacing = {{1.5, 1.1}};
  im.image.origin = {{-20.0, 7.5}};
  const double t = 0.6;
  im.direction << std::cos(t), -std::sin(t), std::sin(t), std::cos(t);
  write_image(im, dir / "in.nrrd");
  const auto out = dir.path / "out";
  const auto r = run_pipeline(quote(dir / "in.nrrd") +
                              " --nodes 60 --max-iterations 3 --threshold 40 --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("iteration"), std::string::npos) << "no progress lines: " << r.err;
  EXPECT_NE(r.out.find("summary"), std::string::npos) << r.out;
  check_mesh_output(im, out, true);

  // The unoptimised grid has the same node count and the same conservation properties.
  const auto grid_out = dir.path / "grid";
  const auto g = run_pipeline(quote(dir / "in.nrrd") + " --nodes 60 --mesher grid -q --export all --out " +
                              quote(grid_out.string()));
  ASSERT_EQ(g.code, 0) << g.err;
  for (const char* f : {"mesh.vtk", "mesh.msh", "mesh.inp"})
    EXPECT_TRUE(std::filesystem::exists(grid_out / f)) << f;  // feb: 3D only
  EXPECT_NE(vim::test::slurp(grid_out / "mesh.inp").find("CPE3"),
            std::string::npos);  // plane strain, as the FEM
  EXPECT_TRUE(g.err.empty()) << "--quiet printed: " << g.err;
  check_mesh_output(im, grid_out, false);
  const auto a = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
  const auto b = nlohmann::json::parse(vim::test::slurp(grid_out / "report.json"));
  EXPECT_EQ(a["mesh"]["nodes"], b["mesh"]["nodes"]);
  EXPECT_EQ(b["mesh"]["mesher"], "grid");

  // --spacing sets the grid instead of the node budget: the report does not claim the default budget.
  const auto spaced_out = dir.path / "spaced";
  const auto s = run_pipeline(quote(dir / "in.nrrd") + " --spacing 10 --mesher grid -q --out " +
                              quote(spaced_out.string()));
  ASSERT_EQ(s.code, 0) << s.err;
  const auto c = nlohmann::json::parse(vim::test::slurp(spaced_out / "report.json"));
  EXPECT_TRUE(c["options"]["nodes"].is_null()) << c["options"];
  EXPECT_EQ(c["options"]["spacing"].get<double>(), 10.0);
}

// --check-invariants runs the mesher's invariant checks after every stage: the run succeeds, the
// report records the option, and the mesh is the same point for point as without the checks.
TEST(CliMesh, CheckInvariantsFlagChecksWithoutChangingTheMesh) {
  vim::test::TempDir dir("cli_inv");
  auto im = phantoms::two_inclusions(40);
  im.image.spacing = {{1.5, 1.1}};
  write_image(im, dir / "in.mha");
  const auto checked = dir.path / "checked", plain = dir.path / "plain";
  const auto a = run_pipeline(quote(dir / "in.mha") +
                              " --nodes 80 --max-iterations 4 --check-invariants -q --export none --out " +
                              quote(checked.string()));
  ASSERT_EQ(a.code, 0) << a.err;
  const auto b =
      run_pipeline(quote(dir / "in.mha") + " --nodes 80 --max-iterations 4 -q --export none --out " +
                   quote(plain.string()));
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ra = nlohmann::json::parse(vim::test::slurp(checked / "report.json"));
  const auto rb = nlohmann::json::parse(vim::test::slurp(plain / "report.json"));
  EXPECT_EQ(ra["options"]["check_invariants"], true);
  EXPECT_EQ(rb["options"]["check_invariants"], kCheckedBuild);
  const auto ma = read_vtu((checked / "mesh.vtu").string()), mb = read_vtu((plain / "mesh.vtu").string());
  ASSERT_EQ(ma->GetNumberOfPoints(), mb->GetNumberOfPoints());
  ASSERT_EQ(ma->GetNumberOfCells(), mb->GetNumberOfCells());
  for (vtkIdType i = 0; i < ma->GetNumberOfPoints(); ++i)
    for (int k = 0; k < 3; ++k) ASSERT_EQ(ma->GetPoint(i)[k], mb->GetPoint(i)[k]) << "point " << i;
}

TEST(CliMesh, ThreeDimensionalObliqueAnisotropic) {
  vim::test::TempDir dir("cli3");
  auto im = phantoms::table1(16);
  im.image.spacing = {{0.2, 0.15, 0.25}};
  im.image.origin = {{3.0, -1.0, 12.0}};
  im.direction = rotation3();
  write_image(im, dir / "in.mha");
  const auto out = dir.path / "out";
  const auto r = run_pipeline(quote(dir / "in.mha") +
                              " --nodes 64 --max-iterations 2 --threshold 1.5 --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  check_mesh_output(im, out, true);

  // A second run into the same (now non-empty) folder is refused and changes nothing.
  const auto before = vim::test::slurp(out / "report.json");
  const auto again = run_pipeline(quote(dir / "in.mha") + " --nodes 64 --out " + quote(out.string()));
  EXPECT_EQ(again.code, 1);
  EXPECT_EQ(vim::test::count_lines(again.err), 1) << again.err;
  EXPECT_NE(again.err.find(out.string()), std::string::npos) << again.err;
  EXPECT_NE(again.err.find("not empty"), std::string::npos) << again.err;
  EXPECT_EQ(vim::test::slurp(out / "report.json"), before);
  // ... unless --overwrite.
  const auto over = run_pipeline(quote(dir / "in.mha") + " --nodes 27 --mesher grid --overwrite -q --out " +
                                 quote(out.string()));
  EXPECT_EQ(over.code, 0) << over.err;
  // The box is 3.2 x 2.4 x 4.0: the budget of 27 gives the per-axis counts that follow the aspect ratio.
  const auto rep = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
  long product = 1;
  for (const auto& n : rep["mesh"]["nodes_per_axis"]) product *= n.get<long>();
  EXPECT_EQ(rep["mesh"]["nodes"].get<long>(), product);
  EXPECT_LE(product, 27);
  EXPECT_GE(product, 12);
  EXPECT_EQ(rep["mesh"]["mesher"], "grid");
}

// A mirroring direction matrix (det < 0; NIfTI files with qfac = -1 have one) turns positively
// oriented frame cells inside out in the world. mesh.vtu keeps every cell positive (VTK's convention):
// the VIM mesh, the grid and the voxel mesher's hexahedra / quads, in 3D and 2D.
TEST(CliMesh, MirroredDirectionKeepsWorldCellsPositive) {
  vim::test::TempDir dir("cli_mirror");
  auto im3 = phantoms::table1(12);
  im3.image.spacing = {{0.3, 0.2, 0.25}};
  im3.image.origin = {{-4.0, 2.0, 9.0}};
  im3.direction = rotation3() * Eigen::Vector3d(1, -1, 1).asDiagonal();
  ASSERT_LT(im3.direction.determinant(), 0.0);
  write_image(im3, dir / "m3.mha");
  auto im2 = phantoms::two_inclusions(30);
  im2.direction << 0, 1, 1, 0;  // x and y swapped: a reflection
  write_image(im2, dir / "m2.mha");
  for (const char* mesher : {"vim", "grid", "voxel"}) {
    const auto o3 = dir.path / (std::string("o3_") + mesher), o2 = dir.path / (std::string("o2_") + mesher);
    const auto r3 =
        run_pipeline(quote(dir / "m3.mha") + " --nodes 40 --max-iterations 2 -q --export none --mesher " +
                     mesher + " --out " + quote(o3.string()));
    ASSERT_EQ(r3.code, 0) << r3.err;
    const auto r2 =
        run_pipeline(quote(dir / "m2.mha") + " --nodes 40 --max-iterations 2 -q --export none --mesher " +
                     mesher + " --out " + quote(o2.string()));
    ASSERT_EQ(r2.code, 0) << r2.err;
    const auto g3 = read_vtu((o3 / "mesh.vtu").string()), g2 = read_vtu((o2 / "mesh.vtu").string());
    ASSERT_GT(g3->GetNumberOfCells(), 0);
    ASSERT_GT(g2->GetNumberOfCells(), 0);
    EXPECT_EQ(count_non_positive_cells<3>(g3), 0) << mesher;
    EXPECT_EQ(count_non_positive_cells<2>(g2), 0) << mesher;
    if (std::string(mesher) != "voxel") {
      check_mesh_output(im3, o3, false);
      check_mesh_output(im2, o2, false);
    }
  }
  // The voxel reference writes mesh.vtu only, and the report says so instead of listing nothing.
  const auto ov = dir.path / "o2_voxel_exports";
  const auto rv = run_pipeline(quote(dir / "m2.mha") + " -q --mesher voxel --out " + quote(ov.string()));
  ASSERT_EQ(rv.code, 0) << rv.err;
  const auto rep = nlohmann::json::parse(vim::test::slurp(ov / "report.json"));
  ASSERT_TRUE(rep["exports"].contains("skipped")) << rep.dump();
  EXPECT_NE(rep["exports"]["skipped"].get<std::string>().find("mesh.vtu only"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(ov / "mesh.vtk"));
}

// --min-dihedral: without it these meshes have angles below the bound; with it none is below, the
// report records the option, and a bound the initial grid cannot meet gives one warning (stderr and
// report.json) and a valid, unchanged mesh.
TEST(CliMesh, MinimumDihedralBoundHoldsOnEveryElement) {
  vim::test::TempDir dir("mindihedral");
  auto im3 = phantoms::table1(24);
  im3.image.spacing = {{0.13, 0.12, 0.125}};
  write_image(im3, dir / "t.mha");
  write_image(phantoms::two_inclusions(40), dir / "d.mha");
  struct Case {
    std::string image, args;
    int dim;
    double bound;
  };
  for (const Case& c : {Case{"t.mha", "--nodes 343 --max-iterations 6", 3, 20.0},
                        Case{"d.mha", "--nodes 80 --max-iterations 6", 2, 35.0}}) {
    const auto free_out = dir.path / ("free_" + c.image), bounded_out = dir.path / ("bounded_" + c.image);
    const std::string common = quote(dir / c.image) + " " + c.args + " -q --export none --out ";
    const auto a = run_pipeline(common + quote(free_out.string()));
    ASSERT_EQ(a.code, 0) << a.err;
    char bound[64];
    std::snprintf(bound, sizeof bound, " --min-dihedral %g", c.bound);
    const auto b = run_pipeline(common + quote(bounded_out.string()) + bound);
    ASSERT_EQ(b.code, 0) << b.err;
    EXPECT_TRUE(b.err.empty()) << b.err;
    const double free_min = vim::test::smallest_angle_deg(read_vtu((free_out / "mesh.vtu").string()), c.dim);
    const double bounded_min =
        vim::test::smallest_angle_deg(read_vtu((bounded_out / "mesh.vtu").string()), c.dim);
    EXPECT_LT(free_min, c.bound) << c.image << ": the bound would not be active";
    EXPECT_GE(bounded_min, c.bound - 1e-9) << c.image;
    const auto rep = nlohmann::json::parse(vim::test::slurp(bounded_out / "report.json"));
    EXPECT_EQ(rep["options"]["min_dihedral_deg"].get<double>(), c.bound);
    EXPECT_NEAR(rep["mesh"]["quality"]["min_dihedral_deg"].get<double>(), bounded_min, 1e-6);
    EXPECT_FALSE(rep.contains("warnings")) << rep["warnings"];
  }

  // 50° is above the regular grid's 45°: nothing can move, and the run says so.
  const auto out = dir.path / "too_high";
  const auto r = run_pipeline(quote(dir / "d.mha") + " --nodes 80 --min-dihedral 50 --export none --out " +
                              quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: vim: 98 of 98 elements are below --min-dihedral 50"), std::string::npos)
      << r.err;
  const auto rep = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
  ASSERT_EQ(rep["warnings"].size(), 1u);
  EXPECT_NE(rep["warnings"][0].get<std::string>().find("smallest angle 45 deg"), std::string::npos)
      << rep["warnings"];
  EXPECT_NEAR(vim::test::smallest_angle_deg(read_vtu((out / "mesh.vtu").string()), 2), 45.0, 1e-9);
}

TEST(CliMesh, UsageErrorsExitWithTwo) {
  vim::test::TempDir dir("usage");
  write_image(phantoms::diamond(20), dir / "d.mha");
  const std::string img = dir / "d.mha", out = dir / "o";
  struct Case {
    std::vector<std::string> args;
    std::string needle;
  };
  const auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{img, "--out", out};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  for (const Case& c : {Case{with({"--lambda", "1"}), "--lambda"},
                        Case{with({"--lambda", "-0.1"}), "--lambda"},
                        Case{with({"--max-dihedral", "90"}), "--max-dihedral"},
                        Case{with({"--max-dihedral", "200"}), "--max-dihedral"},
                        Case{with({"--min-dihedral", "60"}), "--min-dihedral"},
                        Case{with({"--min-dihedral", "-1"}), "--min-dihedral"},
                        Case{with({"--min-radius-ratio", "1"}), "--min-radius-ratio"},
                        Case{with({"--convergence", "0"}), "--convergence"},
                        Case{with({"--energy-convergence", "1"}), "--energy-convergence"},
                        Case{with({"--nodes", "2"}), "--nodes"},
                        Case{with({"--mesher", "tetgen"}), "--mesher"},
                        Case{with({"--degree", "3"}), "--degree"},
                        Case{with({"--export", "stl"}), "--export"},
                        Case{with({"--export", "vtk,none"}), "--export"},
                        Case{{img}, "--out"},
                        Case{{"--out", out}, "image"},
                        Case{with({"--bogus"}), "--bogus"},
                        Case{with({"--nodes", "10", "--spacing", "2"}), "--spacing"},
                        Case{with({"--spacing", "nan"}), "--spacing"},
                        Case{with({"--spacing", "inf"}), "--spacing"},
                        Case{with({"--spacing", "0"}), "--spacing"},
                        Case{with({"--threshold", "nan"}), "--threshold"},
                        Case{with({"--threshold", "inf"}), "--threshold"}}) {
    // In this process: usage errors stop in parsing, before any work (the bad-input suite runs such
    // command lines through the executable).
    const auto r = vim::test::run_pipeline_in_process(c.args);
    const std::string shown = c.args.back();
    EXPECT_EQ(r.code, 2) << shown << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error:", 0), 0u) << r.err;
    EXPECT_EQ(vim::test::count_lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << shown << " → " << r.err;
    EXPECT_EQ(vim::test::count_files(dir.path / "o"), 0);
  }
}

TEST(CliMesh, HelpVersionInfo) {
  const auto h = run_pipeline("--help");
  EXPECT_EQ(h.code, 0);
  for (const char* opt : {"--out",
                          "--nodes",
                          "--spacing",
                          "--lambda",
                          "--max-dihedral",
                          "--min-dihedral",
                          "--min-radius-ratio",
                          "--max-iterations",
                          "--convergence",
                          "--energy-convergence",
                          "--search-width",
                          "--threads",
                          "--seed",
                          "--sizing",
                          "--threshold",
                          "--mesher",
                          "--degree",
                          "--simulate",
                          "--export",
                          "--overwrite",
                          "--quiet",
                          "--verbose",
                          "--version",
                          "--info",
                          "Examples:"})
    EXPECT_NE(h.out.find(opt), std::string::npos) << opt;
  char lambda[64];
  std::snprintf(lambda, sizeof lambda, "default %g;", vim::VimOptions{}.lambda);
  EXPECT_NE(h.out.find(lambda), std::string::npos) << lambda;
  EXPECT_NE(h.out.find("(90, 180)"), std::string::npos);
  const auto v = run_pipeline("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_NE(v.out.find("vim-pipeline 0."), std::string::npos) << v.out;

  vim::test::TempDir dir("info");
  write_image(phantoms::table1(10), dir / "t.mha");
  const auto i = run_pipeline("--info " + quote(dir / "t.mha"));
  EXPECT_EQ(i.code, 0) << i.err;
  EXPECT_NE(i.out.find("10 x 10 x 10"), std::string::npos) << i.out;
  EXPECT_NE(i.out.find("extent:     3 x 3 x 3"), std::string::npos) << i.out;
  EXPECT_NE(i.out.find("min 1  max 2"), std::string::npos) << i.out;
  EXPECT_NE(i.out.find("centre:     1.5 x 1.5 x 1.5  (world, centre of the voxel box)"), std::string::npos)
      << i.out;
  EXPECT_NE(i.out.find("direction:  identity"), std::string::npos) << i.out;
  // Flipped axes (a NIfTI's usual LPS flips) are axis-aligned, a rotation is oblique.
  auto flipped = phantoms::table1(10);
  flipped.direction = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  write_image(flipped, dir / "f.mha");
  const auto f = run_pipeline("--info " + quote(dir / "f.mha"));
  EXPECT_NE(f.out.find("direction:  axis-aligned, flipped or permuted"), std::string::npos) << f.out;
  auto rotated = phantoms::table1(10);
  rotated.direction = rotation3();
  write_image(rotated, dir / "r.mha");
  const auto r = run_pipeline("--info " + quote(dir / "r.mha"));
  EXPECT_NE(r.out.find("direction:  oblique"), std::string::npos) << r.out;
}

// E_D = 0 on the initial mesh has two kinds of cause, and the warning names the right one: a constant
// image (the image term is off), or an initial mesh none of whose elements holds voxel centres of
// different values (elements smaller than the voxels, or faces on the image's edges: E_D0 is then
// estimated). With a mesh that cuts the image's edge nothing is warned.
TEST(CliMesh, ImageTermOffWarningNamesItsCause) {
  vim::test::TempDir dir("cli_ed0");
  OrientedImage<3> split;
  split.image = Image<3>({{6, 6, 6}}, {{1, 1, 1}}, {{0, 0, 0}}, 1.0f);
  for (std::size_t k = 0; k < split.image.data.size(); ++k)
    if (split.image.index_of(k)[0] >= 3) split.image.data[k] = 2.0f;
  write_image(split, dir / "split.mha");
  OrientedImage<3> flat = split;
  std::fill(flat.image.data.begin(), flat.image.data.end(), 5.0f);
  write_image(flat, dir / "flat.mha");
  auto warnings = [&](const std::string& image, const std::string& args) {
    const auto out = dir.path / ("o_" + std::to_string(vim::test::count_files(dir.path)));
    const auto r = run_pipeline(quote(dir / image) + " " + args +
                                " --max-iterations 1 -q --export none --out " + quote(out.string()));
    EXPECT_EQ(r.code, 0) << r.err;
    std::string all;
    const auto report = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
    for (const auto& w : report["warnings"]) all += w.dump() + "\n";
    return all;
  };
  const std::string fine = warnings("split.mha", "--nodes 1000");
  EXPECT_NE(fine.find("E_D = 0 at the start"), std::string::npos) << fine;
  EXPECT_NE(fine.find("E_D0 is estimated"), std::string::npos) << fine;
  EXPECT_NE(fine.find("fewer --nodes"), std::string::npos) << fine;
  EXPECT_EQ(fine.find("constant"), std::string::npos) << fine;
  // 3 x 3 x 3 nodes: grid planes at x = -0.5, 2.5, 5.5, the middle one on the image's edge.
  const std::string aligned = warnings("split.mha", "--nodes 27");
  EXPECT_NE(aligned.find("E_D0 is estimated"), std::string::npos) << aligned;
  // (4 x 4 x 4 nodes: no grid plane on the image's edge at x = 2.5, which would make every element uniform.)
  const std::string coarse = warnings("split.mha", "--nodes 64");
  EXPECT_EQ(coarse.find("E_D0"), std::string::npos) << coarse;
  const std::string constant = warnings("flat.mha", "--nodes 27");
  EXPECT_NE(constant.find("the image is constant"), std::string::npos) << constant;
}

// --verbose adds the per-iteration search detail (nodes searched, candidates, phase times) that a
// default run does not print; --quiet prints nothing at all.
TEST(CliMesh, VerboseAddsDetailQuietPrintsNothing) {
  vim::test::TempDir dir("cli_verbose");
  write_image(phantoms::two_inclusions(40), dir / "in.mha");
  const auto normal =
      run_pipeline(quote(dir / "in.mha") + " --nodes 60 --max-iterations 2 --export none --out " +
                   quote((dir.path / "n").string()));
  ASSERT_EQ(normal.code, 0) << normal.err;
  const auto verbose =
      run_pipeline(quote(dir / "in.mha") + " --nodes 60 --max-iterations 2 --export none -v --out " +
                   quote((dir.path / "v").string()));
  ASSERT_EQ(verbose.code, 0) << verbose.err;
  const auto quiet =
      run_pipeline(quote(dir / "in.mha") + " --nodes 60 --max-iterations 2 --export none -q --out " +
                   quote((dir.path / "q").string()));
  ASSERT_EQ(quiet.code, 0) << quiet.err;
  EXPECT_EQ(normal.err.find("candidate positions evaluated"), std::string::npos) << normal.err;
  EXPECT_NE(verbose.err.find("iteration 1: "), std::string::npos) << verbose.err;
  EXPECT_NE(verbose.err.find("candidate positions evaluated"), std::string::npos) << verbose.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  EXPECT_TRUE(quiet.out.empty()) << quiet.out;
}

// A few huge values among ordinary ones exceed what the double-precision voxel sums can resolve for the
// ordinary ones (1e20 next to 15: element means off by far more than 15): warned about, with the
// accuracy; an ordinary image is not.
TEST(CliMesh, HugeValueRangeIsWarnedAbout) {
  vim::test::TempDir dir("cli_range");
  OrientedImage<3> im;
  im.image = Image<3>({{10, 10, 10}}, {{1, 1, 1}}, {{0, 0, 0}}, 15.0f);
  im.image.data[555] = 1e20f;
  write_image(im, dir / "huge.mha");
  im.image.data[555] = 150.0f;
  write_image(im, dir / "plain.mha");
  auto warnings = [&](const char* name) {
    const auto out = dir.path / (std::string("o_") + name);
    const auto r = run_pipeline(quote(dir / name) + " --nodes 27 --max-iterations 1 -q --export none --out " +
                                quote(out.string()));
    EXPECT_EQ(r.code, 0) << r.err;
    const auto report = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
    return report.contains("warnings") ? report["warnings"].dump() : std::string();
  };
  const std::string huge = warnings("huge.mha");
  EXPECT_NE(huge.find("element means are accurate only to about"), std::string::npos) << huge;
  EXPECT_EQ(warnings("plain.mha").find("accurate only"), std::string::npos);
}

// VTK output (pipeline/include/vim/pipeline/vtk_output.hpp): a mesh written in world coordinates
// is read back with VTK's own reader — points, connectivity, cell types, point/cell fields — and
// the .pvd collection is well-formed XML listing the given steps.
#include <vim/pipeline/vtk_output.hpp>

#include "run_cli.hpp"

#include <gtest/gtest.h>

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <cmath>

using namespace vim;
using namespace vim::pipeline;

TEST(VtkOutput, TetMeshRoundTripInWorldCoordinates) {
  vim::test::TempDir dir("vtu");
  SimplexMesh<3> m;
  m.points = {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(2, 2, 3), Eigen::Vector3d(1, 3, 3), Eigen::Vector3d(1, 2, 4),
              Eigen::Vector3d(2, 3, 4)};
  m.cells = {{{0, 1, 2, 3}}, {{1, 2, 3, 4}}};
  WorldTransform<3> t;
  t.origin = Eigen::Vector3d(1, 2, 3);
  t.direction << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // 90° about z
  UnstructuredGrid g = simplex_grid(m, t);
  g.cell_data["mean"] = Field{1, {10.5, 20.25}};
  g.point_data["disp"] = Field{3, {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1}};
  const auto path = dir.path / "mesh.vtu";
  write_vtu(path, g);
  EXPECT_EQ(vim::test::count_files(dir.path), 1);

  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName(path.c_str());
  r->Update();
  vtkUnstructuredGrid* u = r->GetOutput();
  ASSERT_EQ(u->GetNumberOfPoints(), 5);
  ASSERT_EQ(u->GetNumberOfCells(), 2);
  // World = origin + D (p − origin): frame point (2,2,3) → (1,3,3); (1,3,3) → (0,2,3).
  double p[3];
  u->GetPoint(1, p);
  EXPECT_NEAR(p[0], 1.0, 1e-12);
  EXPECT_NEAR(p[1], 3.0, 1e-12);
  EXPECT_NEAR(p[2], 3.0, 1e-12);
  u->GetPoint(2, p);
  EXPECT_NEAR(p[0], 0.0, 1e-12);
  EXPECT_NEAR(p[1], 2.0, 1e-12);
  EXPECT_EQ(u->GetCellType(1), 10);
  vtkNew<vtkIdList> ids;
  u->GetCellPoints(1, ids);
  ASSERT_EQ(ids->GetNumberOfIds(), 4);
  EXPECT_EQ(ids->GetId(0), 1);
  EXPECT_EQ(ids->GetId(3), 4);
  vtkDataArray* mean = u->GetCellData()->GetArray("mean");
  ASSERT_NE(mean, nullptr);
  EXPECT_DOUBLE_EQ(mean->GetTuple1(1), 20.25);
  vtkDataArray* disp = u->GetPointData()->GetArray("disp");
  ASSERT_NE(disp, nullptr);
  EXPECT_EQ(disp->GetNumberOfComponents(), 3);
  EXPECT_DOUBLE_EQ(disp->GetComponent(4, 2), 1.0);
}

TEST(VtkOutput, TwoDimensionalVectorsArePaddedAndFieldsChecked) {
  vim::test::TempDir dir("vtu2");
  SimplexMesh<2> m;
  m.points = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
  m.cells = {{{0, 1, 2}}};
  UnstructuredGrid g = simplex_grid(m, WorldTransform<2>{});
  EXPECT_EQ(g.vtk_cell_type, 5);
  g.point_data["u"] = Field{2, {1, 2, 3, 4, 5, 6}};
  write_vtu(dir.path / "tri.vtu", g);
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName((dir.path / "tri.vtu").c_str());
  r->Update();
  vtkDataArray* u = r->GetOutput()->GetPointData()->GetArray("u");
  ASSERT_NE(u, nullptr);
  EXPECT_EQ(u->GetNumberOfComponents(), 3);
  EXPECT_DOUBLE_EQ(u->GetComponent(2, 0), 5.0);
  EXPECT_DOUBLE_EQ(u->GetComponent(2, 1), 6.0);
  EXPECT_DOUBLE_EQ(u->GetComponent(2, 2), 0.0);
  // A field of the wrong length is refused and nothing is written.
  g.cell_data["bad"] = Field{1, {1, 2}};
  EXPECT_THROW(write_vtu(dir.path / "bad.vtu", g), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.path / "bad.vtu"));
}

TEST(VtkOutput, PvdListsSteps) {
  vim::test::TempDir dir("pvd");
  write_pvd(dir.path / "sim.pvd", {{0.0, "steps/step_0000.vtu"}, {0.5, "steps/step_0001.vtu"}});
  const std::string s = vim::test::slurp(dir.path / "sim.pvd");
  EXPECT_EQ(s.rfind("<?xml", 0), 0u);
  EXPECT_NE(s.find("<VTKFile type=\"Collection\""), std::string::npos);
  EXPECT_NE(s.find("timestep=\"0.5\" group=\"\" part=\"0\" file=\"steps/step_0001.vtu\""), std::string::npos);
  EXPECT_NE(s.find("</VTKFile>"), std::string::npos);
}

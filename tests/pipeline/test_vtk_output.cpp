// VTK output (pipeline/include/vim/pipeline/output/vtk_output.hpp): a mesh written in world coordinates
// is read back with VTK's own reader — points, connectivity, cell types, point/cell fields — and
// the .pvd collection is well-formed XML listing the given steps.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <cmath>
#include <csignal>
#include <random>
#include <vim/pipeline/output/png.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;

TEST(VtkOutput, TetMeshRoundTripInWorldCoordinates) {
  vim::test::TempDir dir("vtu");
  SimplexMesh<3> m;
  m.points = {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(2, 2, 3), Eigen::Vector3d(1, 3, 3),
              Eigen::Vector3d(1, 2, 4), Eigen::Vector3d(2, 3, 4)};
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

// A write that fails half-way (here a file-size limit of 4 KiB, as on a full disk) is an error
// naming the file, and leaves no file behind: VTK's XML writer still returned 1 then, so a truncated
// mesh.vtu was renamed into place and the run exited 0; ITK's PNG writer aborted the process.
TEST(VtkOutput, FailedWritesAreErrorsAndLeaveNoFile) {
  vim::test::TempDir dir("full");
  SimplexMesh<3> m;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 4000; ++i) m.points.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)));
  for (int c = 0; c + 3 < 4000; c += 4) m.cells.push_back({{c, c + 1, c + 2, c + 3}});
  UnstructuredGrid g = simplex_grid(m, WorldTransform<3>{});
  std::vector<double> noise(m.cells.size());
  for (double& v : noise) v = u(rng);
  g.cell_data["mean"] = Field{1, noise};
  Canvas canvas(300, 200);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 300; ++x)
      canvas.fill_polygon(
          {{double(x), double(y)}, {x + 1.0, double(y)}, {x + 1.0, y + 1.0}, {double(x), y + 1.0}},
          {static_cast<std::uint8_t>(rng()), static_cast<std::uint8_t>(rng()),
           static_cast<std::uint8_t>(rng())});

  struct Limit {  // RLIMIT_FSIZE for this scope; SIGXFSZ ignored so that write() fails with EFBIG
    rlimit old{};
    void (*old_handler)(int) = nullptr;
    explicit Limit(rlim_t bytes) {
      getrlimit(RLIMIT_FSIZE, &old);
      old_handler = std::signal(SIGXFSZ, SIG_IGN);
      rlimit r = old;
      r.rlim_cur = bytes;
      setrlimit(RLIMIT_FSIZE, &r);
    }
    ~Limit() {
      setrlimit(RLIMIT_FSIZE, &old);
      std::signal(SIGXFSZ, old_handler);
    }
  };
  {
    Limit limit(4096);
    for (const char* name : {"mesh.vtu", "slice.png"}) {
      try {
        if (std::string(name) == "mesh.vtu")
          write_vtu(dir.path / name, g);
        else
          canvas.write_png(dir.path / name);
        ADD_FAILURE() << name << ": the write past the limit did not throw";
      } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      }
      EXPECT_EQ(vim::test::count_files(dir.path), 0) << name;
    }
  }
  // Without the limit both are written and read back.
  write_vtu(dir.path / "mesh.vtu", g);
  canvas.write_png(dir.path / "slice.png");
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName((dir.path / "mesh.vtu").c_str());
  r->Update();
  EXPECT_EQ(r->GetOutput()->GetNumberOfCells(), static_cast<vtkIdType>(m.cells.size()));
  const Canvas back = Canvas::read_png(dir.path / "slice.png");
  ASSERT_EQ(back.width(), 300);
  for (int y = 0; y < 200; y += 7)
    for (int x = 0; x < 300; x += 5) ASSERT_EQ(back.at(x, y), canvas.at(x, y)) << x << "," << y;
}

// The needle's shape in the step outputs: steps/needle_NNNN.vtp (one polyline, read back by VTK's reader)
// equals the shape and tip of report.json and needle.csv, simulation.pvd shows it beside the step's grid,
// and figures/needle_path.png draws it.
#include <gtest/gtest.h>
#include <unistd.h>
#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkXMLPolyDataReader.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vim/pipeline/output/figures.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation_test_util.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::pipeline::simulation_test;

namespace {

namespace fs = std::filesystem;

const char* kShapeTargets = "[{name: ahead, position: [1, 0.5, 15]}, {name: beside, position: [2, 1, 6]}]";

// A bevelled flexible needle (it bends: 0.1 mm and more at the tip) or the rigid needle along the symmetric
// block's axis, 4 steps, every step written below `dir`.
SimulationResult<3> written_run(const fs::path& dir, bool flexible) {
  const SimulationOptions o = writing_into(dir);
  std::string n =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 4, diameter: 1, friction: {model: stick}, "
      "cutting_force: 5";
  if (flexible)
    n += ", flexible: {youngs_modulus: 2.0e+5, inner_diameter: 0.6, free_length: 3}, "
         "bevel: {angle: 30, side: [1, 0, 0]}";
  return run_simulation<3>(axis_block(), parse_scenario_text(yaml(n + "}", kShapeTargets), 3), o);
}

struct Polyline {
  std::vector<V3> points, deflection;
  vtkIdType lines = 0;
};

// steps/needle_NNNN.vtp through VTK's XML PolyData reader.
Polyline read_vtp(const fs::path& file) {
  vtkNew<vtkXMLPolyDataReader> reader;
  reader->SetFileName(file.string().c_str());
  reader->Update();
  vtkPolyData* pd = reader->GetOutput();
  Polyline p;
  p.lines = pd->GetNumberOfLines();
  vtkDataArray* d = pd->GetPointData()->GetArray("deflection");
  vtkNew<vtkIdList> ids;
  pd->GetLines()->InitTraversal();
  if (p.lines != 1 || !d || !pd->GetLines()->GetNextCell(ids)) return p;
  for (vtkIdType i = 0; i < ids->GetNumberOfIds(); ++i) {  // in the line's order
    double x[3];
    pd->GetPoint(ids->GetId(i), x);
    p.points.emplace_back(x[0], x[1], x[2]);
    const double* v = d->GetTuple3(ids->GetId(i));
    p.deflection.emplace_back(v[0], v[1], v[2]);
  }
  return p;
}

std::string file_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string step_name(const char* format, std::size_t k) {
  char name[40];
  std::snprintf(name, sizeof name, format, static_cast<int>(k));
  return name;
}

}  // namespace

// Every written step's needle_NNNN.vtp holds one polyline whose points are report.json's needle shape of
// that step (from the holder, 3 mm before the entry on the planned line, to the tip of needle.csv), with
// each point's deflection from the planned line (the z axis: its x and y); simulation.pvd lists it as
// part 1 of the step, beside the step's grid.
TEST(NeedleShapeOutputs, VtpIsTheBentNeedleOfTheReport) {
  const fs::path dir = fs::temp_directory_path() / ("vim_needle_vtp_" + std::to_string(::getpid()));
  const SimulationResult<3> res = written_run(dir, true);
  const NeedleRun<3>& r = res.needles.at(0);
  const nlohmann::json& per = res.report["needles"][0]["per_step"];
  ASSERT_EQ(per["needle_shape"].size(), r.depth.size());
  const std::string pvd = file_text(dir / "simulation.pvd");
  double largest = 0.0;
  for (std::size_t k = 0; k < r.depth.size(); ++k) {
    const std::string file = step_name("steps/needle_%04d.vtp", k);
    const Polyline p = read_vtp(dir / file);
    const nlohmann::json& shape = per["needle_shape"][k];
    ASSERT_EQ(p.lines, 1) << file;
    ASSERT_EQ(p.points.size(), shape.size()) << file;
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      const V3 expected(shape[i][0].get<double>(), shape[i][1].get<double>(), shape[i][2].get<double>());
      EXPECT_LT((p.points[i] - expected).norm(), 1e-9) << file << " point " << i;
      EXPECT_LT((p.deflection[i] - V3(expected.x(), expected.y(), 0.0)).norm(), 1e-9)
          << file << " point " << i;
      largest = std::max(largest, p.deflection[i].norm());
    }
    EXPECT_LT((p.points.back() - r.tip[k]).norm(), 1e-9) << file;  // needle.csv's and report.json's tip
    EXPECT_LT((p.points.front() - V3(0, 0, -3)).norm(), 1e-9) << file;
    std::ostringstream entry;
    entry << "timestep=\"" << r.depth[k] << "\" group=\"\" part=\"1\" file=\"" << file << "\"";
    EXPECT_NE(pvd.find(entry.str()), std::string::npos) << entry.str();
    EXPECT_NE(pvd.find("part=\"0\" file=\"" + step_name("steps/step_%04d.vtu", k) + "\""), std::string::npos);
  }
  EXPECT_GT(largest, 0.1);  // the needle bends: a planned straight line would differ
  for (const auto& e : fs::directory_iterator(dir / "steps"))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  fs::remove_all(dir);
}

// The rigid needle is a straight polyline from the entry to the tip, deflection 0, at every step.
TEST(NeedleShapeOutputs, RigidNeedleIsAStraightPolyline) {
  const fs::path dir = fs::temp_directory_path() / ("vim_rigid_vtp_" + std::to_string(::getpid()));
  const SimulationResult<3> res = written_run(dir, false);
  const NeedleRun<3>& r = res.needles.at(0);
  const std::string pvd = file_text(dir / "simulation.pvd");
  for (std::size_t k = 0; k < r.depth.size(); ++k) {
    const std::string file = step_name("steps/needle_%04d.vtp", k);
    const Polyline p = read_vtp(dir / file);
    ASSERT_EQ(p.points.size(), 2u) << file;
    EXPECT_LT(p.points.front().norm(), 1e-12) << file;
    EXPECT_LT((p.points.back() - V3(0, 0, r.depth[k])).norm(), 1e-12) << file;
    EXPECT_LT((p.points.back() - r.tip[k]).norm(), 1e-12) << file;
    for (const V3& d : p.deflection) EXPECT_EQ(d.norm(), 0.0) << file;
    EXPECT_NE(pvd.find("part=\"1\" file=\"" + file + "\""), std::string::npos) << file;
  }
  fs::remove_all(dir);
}

// figures/needle_path.png of the bent needle: a valid PNG (read back by ITK's decoder) with the needle
// drawn where the figure's panels put its final shape (dark pixels along it), a white background away
// from it, and the targets' rings.
TEST(NeedleShapeOutputs, PathFigureDrawsTheNeedle) {
  const fs::path dir = fs::temp_directory_path() / ("vim_needle_path_" + std::to_string(::getpid()));
  const SimulationResult<3> res = written_run(dir / "run", true);
  const NeedleRun<3>& r = res.needles.at(0);
  std::vector<V3> moved;
  for (std::size_t t = 0; t < res.target_positions.size(); ++t)
    moved.push_back(res.target_positions[t] + r.target_displacement.back()[t]);
  ASSERT_EQ(moved.size(), 2u);
  const fs::path png = dir / "figures" / "needle_path.png";
  fs::create_directories(png.parent_path());
  const nlohmann::json fig = write_needle_path_figure<3>(png, r.entry, r.axis, r.shape.back(), r.tip,
                                                         res.target_positions, moved, "mm");
  const Canvas c = Canvas::read_png(png);
  const double m = fig["deviation_magnified"].get<double>();
  ASSERT_EQ(fig["panels"].size(), 2u);
  int dark = 0, samples = 0;
  for (const auto& panel : fig["panels"]) {
    const V3 e(panel["lateral"][0].get<double>(), panel["lateral"][1].get<double>(),
               panel["lateral"][2].get<double>());
    EXPECT_NEAR(e.dot(r.axis), 0.0, 1e-12);
    const double scale = panel["scale"], u_min = panel["u_min"], v_min = panel["v_min"];
    const double x0 = panel["x_offset"], y0 = panel["y_offset"];
    const auto pixel = [&](const V3& x, double magnify) {
      const double u = (x - r.entry).dot(r.axis);
      const double v = magnify * (x - r.entry - u * r.axis).dot(e);
      return Eigen::Vector2d(x0 + (u - u_min) * scale, y0 + (v - v_min) * scale);
    };
    const std::vector<V3>& shape = r.shape.back();
    for (std::size_t i = 1; i < shape.size(); ++i)
      for (double t : {0.25, 0.5, 0.75}) {  // along each segment, off the other lines' ends
        const Eigen::Vector2d p = pixel((1 - t) * shape[i - 1] + t * shape[i], m);
        const Rgb got = c.at(static_cast<int>(p.x()), static_cast<int>(p.y()));
        ++samples;
        dark += got.r < 128 && got.g < 128 && got.b < 128;
      }
    for (const V3& target : res.target_positions) {  // a ring of 5 px: its left edge is blue
      const Eigen::Vector2d p = pixel(target, 1.0);
      const Rgb got = c.at(static_cast<int>(p.x() - 5.0), static_cast<int>(p.y()));
      EXPECT_GT(got.b, got.r) << "target ring";
    }
    // Background away from the needle: the panel's corner inside its frame.
    EXPECT_EQ(c.at(static_cast<int>(x0) + 3, static_cast<int>(y0) + 3), colors::white);
  }
  EXPECT_GT(samples, 20);
  EXPECT_EQ(dark, samples);
  EXPECT_GT(m * r.tip_deviation.back().norm() * fig["panels"][0]["scale"].get<double>(), 10.0);
  fs::remove_all(dir);
}

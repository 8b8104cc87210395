// A procedure on a label image through the real executable (docs/labels.md, docs/procedure.md,
// docs/dose.md): a target at a label's centroid, the dose region given by a label, the seeds in the
// step files and figures/seeds.png. Truths: the centroid and the dose region's points recomputed by brute
// force from the label image written here (the documented nearest-voxel rule), D90 re-sorted from the
// written dose grid, the seeds' step files against seeds.csv (count = seeds released by that step, at
// the plan at release, at the final position in the last step), the figure's pixels at the final
// positions it reports the projection of.
#include <gtest/gtest.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/figures.hpp>

#include "run_cli.hpp"

namespace vim::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// 20×20×24 voxels of 1 mm: 1 tissue; 2 gland, a ball of radius 6 at (10, 10, 12) cut at x ≤ 13;
// 3 lesion, voxel centres x in [6, 9), y in [7, 11), z in [9, 14).
OrientedImage<3> gland_image() {
  OrientedImage<3> im;
  im.image = Image<3>({{20, 20, 24}}, {{1.0, 1.0, 1.0}}, {{0.5, 0.5, 0.5}}, 1.0f);
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k) {
    const auto p = im.image.point_of(im.image.index_of(k));
    if ((p - Eigen::Vector3d(10.0, 10.0, 12.0)).norm() <= 6.0 && p[0] <= 13.0) im.image.data[k] = 2.0f;
    if (p[0] >= 6.0 && p[0] < 9.0 && p[1] >= 7.0 && p[1] < 11.0 && p[2] >= 9.0 && p[2] < 14.0)
      im.image.data[k] = 3.0f;
  }
  return im;
}

const std::string kModuli = " --label-modulus 1=10 --label-modulus 2=20 --label-modulus 3=40";

std::string scenario(const std::string& target_label, const std::string& dose_label) {
  return "labels: {2: {name: gland}, 3: {name: lesion}}\n"
         "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
         "procedure:\n"
         "  - insert: {name: a, entry: [11.3, 10.2, 0], direction: [0, 0, 1], depth: 18, steps: 6, diameter: "
         "1,\n"
         "             friction: {model: stick-slip, max_shear_per_length: 0.5}, seeds: [8, 12, 16]}\n"
         "  - withdraw: {needle: a, steps: 6}\n"
         "targets: [{name: lesion_c, label: " +
         target_label +
         ", at: centroid}]\n"
         "dose: {seed_model: amersham_6711, air_kerma_strength: 0.5, grid: 2, region: {label: " +
         dose_label + "}}\n";
}

// seeds.csv: per seed its columns by name.
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) head.push_back(c);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::map<std::string, std::string> row;
    std::size_t k = 0;
    for (std::string c; std::getline(ls, c, ',') && k < head.size(); ++k) row[head[k]] = c;
    rows.push_back(row);
  }
  return rows;
}

Eigen::Vector3d column(const std::map<std::string, std::string>& row, const std::string& what) {
  return {std::stod(row.at(what + "_x")), std::stod(row.at(what + "_y")), std::stod(row.at(what + "_z"))};
}

}  // namespace

TEST(LabelsProcedure, LabelTargetDoseRegionAndSeedFiles) {
  const test::TempDir dir("labels_procedure");
  const OrientedImage<3> im = gland_image();
  write_image(im, dir / "labels.mha");
  std::ofstream(dir / "s.yaml") << scenario("lesion", "gland");
  const auto r = test::run_pipeline("--labels " + test::quote(dir / "labels.mha") + kModuli +
                                    " --nodes 600 --simulate " + test::quote(dir / "s.yaml") + " -q -o " +
                                    test::quote(dir / "out"));
  ASSERT_EQ(r.code, 0) << r.err;
  const fs::path out = dir.path / "out";
  const json report = json::parse(test::slurp(out / "report.json"));
  const json& sim = report["simulation"];

  // The lesion target: the mean of the lesion voxels' centres.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double n = 0.0;
  for (std::size_t k = 0; k < im.image.voxel_count(); ++k)
    if (im.image.data[k] == 3.0f) sum += im.image.point_of(im.image.index_of(k)), n += 1.0;
  ASSERT_EQ(n, 60.0);
  const std::vector<double> at = sim["target_positions"]["lesion_c"];
  ASSERT_EQ(at.size(), 3u);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(at[a], sum[a] / n, 1e-9) << a;

  // The dose region: the grid points (cells of 2 mm over the box, at their centres) whose nearest label
  // voxel (halfway: the larger index) is the gland; D90 of the planned dose re-sorted over them.
  const OrientedImage<3> planned = read_image<3>((out / "dose_planned.mha").string());
  std::vector<double> region;
  for (std::size_t k = 0; k < planned.image.voxel_count(); ++k) {
    const auto x = planned.image.point_of(planned.image.index_of(k));
    Image<3>::Index v{};
    for (int a = 0; a < 3; ++a)
      v[a] = std::clamp(static_cast<long>(std::floor((x[a] - 0.5) + 0.5)), 0L, im.image.size[a] - 1);
    if (im.image.at(v) == 2.0f) region.push_back(planned.image.data[k]);
  }
  const json& dose = sim["dose"];
  ASSERT_GT(region.size(), 20u);
  EXPECT_LT(region.size(), planned.image.voxel_count() / 4);
  EXPECT_EQ(dose["region_points"].get<std::size_t>(), region.size());
  std::sort(region.begin(), region.end(), std::greater<double>());
  const double d90 = region[static_cast<std::size_t>(std::ceil(0.9 * region.size())) - 1];
  EXPECT_NEAR(dose["planned"]["d90_gy"].get<double>(), d90, 1e-5 * d90);

  // The seeds in the step files: those released by step k, at X + u_k(P); at release on the plan, in the
  // last step at their final positions of seeds.csv.
  const auto seeds = read_csv(out / "seeds.csv");
  ASSERT_EQ(seeds.size(), 3u);
  for (int k = 0; k <= 12; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "a/steps/seeds_%04d.vtu", k);
    ASSERT_TRUE(fs::exists(out / name)) << name;
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName((out / name).string().c_str());
    reader->Update();
    vtkUnstructuredGrid* g = reader->GetOutput();
    std::vector<const std::map<std::string, std::string>*> released;
    for (const auto& s : seeds)
      if (std::stoi(s.at("release_step")) <= k) released.push_back(&s);
    ASSERT_EQ(g->GetNumberOfPoints(), static_cast<vtkIdType>(released.size())) << name;
    for (std::size_t i = 0; i < released.size(); ++i) {
      double p[3];
      g->GetPoint(static_cast<vtkIdType>(i), p);
      const int release = std::stoi(released[i]->at("release_step"));
      const Eigen::Vector3d expected = k == 12        ? column(*released[i], "final")
                                       : k == release ? column(*released[i], "planned")
                                                      : Eigen::Vector3d(p[0], p[1], p[2]);
      EXPECT_LT((Eigen::Vector3d(p[0], p[1], p[2]) - expected).norm(), 1e-8) << name << " seed " << i;
      EXPECT_EQ(g->GetPointData()->GetArray("needle")->GetTuple1(static_cast<vtkIdType>(i)), 1.0);
    }
  }
  EXPECT_TRUE(fs::exists(out / "a" / "seeds.pvd"));

  // figures/seeds.png: a red disk at every final position in every projection.
  const json& fig = report["figures"]["simulation"]["seeds"];
  ASSERT_EQ(fig["panels"].size(), 3u) << fig.dump();
  const Canvas png = Canvas::read_png(out / "figures" / "seeds.png");
  long blue = 0;
  for (int y = 0; y < png.height(); ++y)
    for (int x = 0; x < png.width(); ++x) blue += png.at(x, y) == kPlannedSeed ? 1 : 0;
  EXPECT_GT(blue, 0);
  for (const json& panel : fig["panels"])
    for (const auto& s : seeds) {
      const Eigen::Vector3d f = column(s, "final");
      const int u = panel["u"], v = panel["v"];
      const double px = panel["x_offset"].get<double>() +
                        (f[u] - panel["u_min"].get<double>()) * panel["scale"].get<double>();
      const double py = panel["y_offset"].get<double>() +
                        (f[v] - panel["v_min"].get<double>()) * panel["scale"].get<double>();
      EXPECT_TRUE(png.at(static_cast<int>(px), static_cast<int>(py)) == kFinalSeed) << "panel " << u << v;
    }
}

TEST(LabelsProcedure, UnknownLabelsAreOneLineErrors) {
  const test::TempDir dir("labels_procedure_errors");
  write_image(gland_image(), dir / "labels.mha");
  struct Case {
    std::string yaml, args, expected;
  };
  const std::string labels = "--labels " + test::quote(dir / "labels.mha") + kModuli;
  const std::vector<Case> cases = {
      {scenario("prostate", "gland"), labels, "s.yaml:7: target 'lesion_c' {label: prostate}: no label of"},
      {scenario("lesion", "9"), labels, "s.yaml:8: region {label: 9}: no label of"},
      {"boundary_conditions: [{type: fixed, region: {box_face: z_max}},\n"
       "  {type: displacement, region: {box_face: z_min}, value: [0, 0, 0.1]}]\n"
       "targets: [{name: t, label: lesion}]\n",
       test::quote(dir / "labels.mha"), "s.yaml:3: target 't' {label: lesion} needs a label image"},
  };
  int k = 0;
  for (const Case& c : cases) {
    std::ofstream(dir / "s.yaml") << c.yaml;
    const auto r = test::run_pipeline(c.args + " --simulate " + test::quote(dir / "s.yaml") + " -o " +
                                      test::quote(dir / ("out" + std::to_string(k++))));
    EXPECT_EQ(r.code, 1) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_EQ(test::count_lines(r.err), 1) << r.err;
  }
}

}  // namespace vim::pipeline

// Needle-free scenarios (static load cases) and the largest strain per step, through the real CLI.
// Truths: the analytic uniaxial state of a homogeneous block on sliding supports (compressed by a
// prescribed displacement δ: ε_zz = −δ/L, ε_xx = ε_yy = νδ/L, u linear; under a pressure p:
// ε_zz = −p/E), which P1 and Q1 reproduce exactly; and, for a needle run, the largest principal strain
// recomputed here from the strain tensors of the step files.
#include <gtest/gtest.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;
using vim::test::quote;
using vim::test::run_pipeline;
namespace fs = std::filesystem;

namespace {

constexpr double kBlockE = 10.0, kBlockNu = 0.3,
                 kL = 20.0;  // modulus (kPa), Poisson ratio, block height (mm)

// A homogeneous 10 x 10 x 20 mm block of 1 mm voxels, box [0,10] x [0,10] x [0,20].
void write_block(const fs::path& path) {
  OrientedImage<3> img;
  img.image = Image<3>({{10, 10, 20}}, {{1, 1, 1}}, {{0.5, 0.5, 0.5}}, static_cast<float>(kBlockE));
  write_image<3>(img, path.string());
}

// Sliding supports on x_min, y_min, z_min (one component each) and `load` on z_max.
std::string static_scenario(const std::string& load) {
  return "material: {youngs_modulus: image, poisson_ratio: " + std::to_string(kBlockNu) +
         "}\n"
         "boundary_conditions:\n"
         "  - {type: fixed, region: {box_face: x_min}, components: [x]}\n"
         "  - {type: fixed, region: {box_face: y_min}, components: [y]}\n"
         "  - {type: fixed, region: {box_face: z_min}, components: [z]}\n"
         "  - " +
         load +
         "\n"
         "targets: [{name: top, position: [7, 3, 16]}]\n";
}

vtkSmartPointer<vtkUnstructuredGrid> read_vtu(const fs::path& path) {
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName(path.string().c_str());
  r->Update();
  return r->GetOutput();
}

// Runs the CLI on the block; returns report.json (empty on failure).
nlohmann::json run(const vim::test::TempDir& dir, const std::string& yaml, const std::string& mesher,
                   const std::string& name) {
  std::ofstream(dir / (name + ".yaml")) << yaml;
  const auto r = run_pipeline(quote(dir / "block.mha") + " --mesher " + mesher +
                              " --nodes 300 --export none -q --simulate " + quote(dir / (name + ".yaml")) +
                              " --out " + quote(dir / name));
  EXPECT_EQ(r.code, 0) << r.err;
  std::ifstream f(dir.path / name / "report.json");
  nlohmann::json report;
  if (f) f >> report;
  return report;
}

// The largest |eigenvalue| of the 3x3 tensors of a cell array (9 components, row-major).
double largest_principal(vtkDataArray* strain, vtkIdType cell) {
  Eigen::Matrix3d e;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) e(a, b) = strain->GetComponent(cell, 3 * a + b);
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(e).eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

// A prescribed compression δ of the top face: one solve, step 0 written like a needle step (same
// fields), no needle.csv; displacements, the target and the largest strain δ/L are the analytic ones,
// on the grid (P1) and the voxel reference (Q1). 15% compression is beyond small strain: warned, naming
// step 0; 5% is not.
TEST(StaticLoad, PrescribedCompressionMatchesTheUniaxialSolution) {
  vim::test::TempDir dir("static");
  write_block(dir.path / "block.mha");
  for (const std::string mesher : {"grid", "voxel"}) {
    for (const double delta : {1.0, 3.0}) {
      const std::string name = mesher + (delta > 2 ? "_large" : "_small");
      const std::string load = "{type: displacement, region: {box_face: z_max}, value: [0, 0, " +
                               std::to_string(-delta) + "], components: [z]}";
      const auto report = run(dir, static_scenario(load), mesher, name);
      ASSERT_TRUE(report.contains("simulation")) << name;
      const auto& sim = report["simulation"];
      const double strain = delta / kL;
      EXPECT_NEAR(sim["max_strain"].get<double>(), strain, 1e-8) << name;
      EXPECT_NEAR(sim["static_load"]["max_strain"].get<double>(), strain, 1e-8) << name;
      // The target at (7, 3, 16): u = (ν ε x, ν ε y, −ε z) with ε = δ/L.
      const Eigen::Vector3d expected(kBlockNu * strain * 7, kBlockNu * strain * 3, -strain * 16);
      const auto& u = sim["static_load"]["targets"]["top"]["displacement"];
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(u[a].get<double>(), expected[a], 1e-8) << name << " axis " << a;
      EXPECT_FALSE(fs::exists(dir.path / name / "needle.csv")) << name;
      EXPECT_TRUE(fs::exists(dir.path / name / "simulation.pvd")) << name;
      const auto step = read_vtu(dir.path / name / "steps" / "step_0000.vtu");
      for (const char* field : {"strain", "stress", "von_mises", "youngs_modulus"})
        EXPECT_NE(step->GetCellData()->GetArray(field), nullptr) << name << " " << field;
      vtkDataArray* disp = step->GetPointData()->GetArray("displacement");
      ASSERT_NE(disp, nullptr) << name;
      double worst = 0.0;
      for (vtkIdType i = 0; i < step->GetNumberOfPoints(); ++i) {
        double p[3];
        step->GetPoint(i, p);
        const Eigen::Vector3d truth(kBlockNu * strain * p[0], kBlockNu * strain * p[1], -strain * p[2]);
        for (int a = 0; a < 3; ++a) worst = std::max(worst, std::abs(disp->GetComponent(i, a) - truth[a]));
      }
      EXPECT_LT(worst, 1e-8) << name;
      const std::string warnings = report.contains("warnings") ? report["warnings"].dump() : "";
      const bool warned =
          warnings.find("the static load case: the largest strain in the model is") != std::string::npos;
      EXPECT_EQ(warned, delta > 2) << name << ": " << warnings;
      if (warned) {
        EXPECT_NE(warnings.find("at step 0"), std::string::npos) << warnings;
      }
    }
  }
}

// A pressure p on the top face (a probe pressing on the tissue): ε_zz = −p/E everywhere, the largest
// principal strain p/E, on the VIM mesh (any mesh of the block represents the uniform state exactly).
TEST(StaticLoad, PressureGivesTheUniaxialStrain) {
  vim::test::TempDir dir("static_p");
  write_block(dir.path / "block.mha");
  const double p = 0.4;
  const auto report =
      run(dir, static_scenario("{type: pressure, region: {box_face: z_max}, value: 0.4}"), "vim", "p");
  ASSERT_TRUE(report.contains("simulation"));
  EXPECT_NEAR(report["simulation"]["max_strain"].get<double>(), p / kBlockE, 1e-8);
  const auto& u = report["simulation"]["static_load"]["targets"]["top"]["displacement"];
  EXPECT_NEAR(u[2].get<double>(), -p / kBlockE * 16, 1e-8);
  EXPECT_NEAR(u[0].get<double>(), kBlockNu * p / kBlockE * 7, 1e-8);
  EXPECT_TRUE(fs::exists(dir.path / "p" / "figures" / "deformed.png"));
}

// A needle run reports the largest strain of every step in needle.csv and report.json: it equals the
// largest principal strain recomputed from the strain tensors of the step files, and the warning names
// the first step at which it exceeds 10%.
TEST(StaticLoad, NeedleRunsReportTheLargestStrainOfEveryStep) {
  vim::test::TempDir dir("strain");
  write_block(dir.path / "block.mha");
  const std::string yaml =
      "material: {youngs_modulus: image, poisson_ratio: 0.3}\n"
      "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
      "needle: {entry: [5.2, 4.9, 0], direction: [0, 0, 1], depth: 12, steps: 4, diameter: 1, friction: "
      "{model: "
      "stick}}\n";
  const auto report = run(dir, yaml, "grid", "n");
  ASSERT_TRUE(report.contains("simulation"));
  std::ifstream csv(dir.path / "n" / "needle.csv");
  std::string line;
  std::getline(csv, line);
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) head.push_back(c);
  }
  const auto column = std::find(head.begin(), head.end(), "max_strain") - head.begin();
  ASSERT_LT(static_cast<std::size_t>(column), head.size()) << line;
  const auto near_column = std::find(head.begin(), head.end(), "near_field_strain") - head.begin();
  ASSERT_LT(static_cast<std::size_t>(near_column), head.size()) << line;
  const auto& per_step = report["simulation"]["needles"][0]["per_step"]["max_strain"];
  int first_large = -1;
  for (int k = 0; std::getline(csv, line); ++k) {
    std::vector<std::string> row;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) row.push_back(c);
    const double reported = std::stod(row[static_cast<std::size_t>(column)]);
    EXPECT_NEAR(per_step[static_cast<std::size_t>(k)].get<double>(), reported, 1e-9 * (1 + reported));
    const auto step = read_vtu(dir.path / "n" / "steps" / ("step_000" + std::to_string(k) + ".vtu"));
    vtkDataArray* strain = step->GetCellData()->GetArray("strain");
    ASSERT_NE(strain, nullptr);
    double largest = 0.0;
    for (vtkIdType c = 0; c < step->GetNumberOfCells(); ++c)
      largest = std::max(largest, largest_principal(strain, c));
    // max_strain: the cells' largest, or the shaft's near field on the needle's surface if larger.
    const double near = std::stod(row[static_cast<std::size_t>(near_column)]);
    EXPECT_NEAR(reported, std::max(largest, near), 1e-6 * (1 + reported)) << "step " << k;
    if (first_large < 0 && largest > 0.1) first_large = k;
  }
  ASSERT_GT(first_large, 0) << "a 12 mm insertion into a 20 mm block strains it beyond 10%";
  const std::string warnings = report.contains("warnings") ? report["warnings"].dump() : "";
  EXPECT_NE(warnings.find("at step " + std::to_string(first_large) + " (the first step above 0.1"),
            std::string::npos)
      << warnings;
}

namespace {

// ∂W/∂λ_i of the neo-Hookean energy W = C10 (J^(−2/3) Σλ² − 3) + (J − 1)²/D₁ at F = diag(λ),
// C10 = μ/2, D₁ = 2/K (hand-written from the textbook μ, K of E, ν).
double neo_hookean_piola(const std::array<double, 3>& l, int i) {
  const double c10 = kBlockE / (4 * (1 + kBlockNu)), d1 = 6 * (1 - 2 * kBlockNu) / kBlockE;
  const double J = l[0] * l[1] * l[2], I1 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  return c10 * std::pow(J, -2.0 / 3.0) * (2 * l[i] - (2.0 / 3.0) * I1 / l[i]) + 2 * (J - 1) * J / (d1 * l[i]);
}
// The root in [lo, hi] of an increasing function, by bisection.
template <class F>
double bisect(F f, double lo, double hi) {
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > 0 ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}
// Uniaxial stress along z with stretch l3: the lateral stretch of P₁₁ = P₂₂ = 0.
double lateral(double l3) {
  return bisect([l3](double l) { return neo_hookean_piola({{l, l, l3}}, 0); }, 0.2, 3.0);
}

}  // namespace

// material.model: neo-hookean on the block: a prescribed compression of 15% (λ₃ = 0.85) and a dead
// pressure p on the top face (P₃₃ = −p on the reference area) give the homogeneous uniaxial state of the
// energy, solved here by scalar root finds: the target at (7, 3, 16) moves by ((λ − 1) 7, (λ − 1) 3,
// (λ₃ − 1) 16), on the grid (P1) and the voxel reference (Q1); report.json holds the load steps.
TEST(StaticLoad, NeoHookeanUniaxialStatesMatchTheClosedForm) {
  vim::test::TempDir dir("static_nh");
  write_block(dir.path / "block.mha");
  const double p = 1.5;
  for (const std::string mesher : {"grid", "voxel"})
    for (const bool pressure : {false, true}) {
      const std::string name = mesher + (pressure ? "_p" : "_u");
      std::string yaml =
          static_scenario(pressure ? "{type: pressure, region: {box_face: z_max}, value: 1.5}"
                                   : "{type: displacement, region: {box_face: z_max}, value: [0, "
                                     "0, -3], components: [z]}");
      yaml.replace(yaml.find("material: {"), 11, "material: {model: neo-hookean, ");
      const auto report = run(dir, yaml, mesher, name);
      ASSERT_TRUE(report.contains("simulation")) << name;
      const auto& sl = report["simulation"]["static_load"];
      EXPECT_EQ(sl["material_model"], "neo-hookean");
      const double l3 = pressure ? bisect(
                                       [p](double l) {
                                         return neo_hookean_piola({{lateral(l), lateral(l), l}}, 2) + p;
                                       },
                                       0.3, 1.0)
                                 : 1.0 - 3.0 / kL;
      const double l = lateral(l3);
      const Eigen::Vector3d expected((l - 1) * 7, (l - 1) * 3, (l3 - 1) * 16);
      const auto& u = sl["targets"]["top"]["displacement"];
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(u[a].get<double>(), expected[a], 1e-6 * 16) << name << " axis " << a;
      ASSERT_FALSE(sl["newton"]["load_steps"].empty()) << name;
      for (const auto& step : sl["newton"]["load_steps"]) {
        const auto& r = step["residual_norm"];
        EXPECT_LE(r.back().get<double>(), 1e-10 * r.front().get<double>()) << name;
      }
      EXPECT_EQ(sl["newton"]["load_steps"].back()["load_factor"].get<double>(), 1.0) << name;
      const std::string warnings = report.contains("warnings") ? report["warnings"].dump() : "";
      EXPECT_EQ(warnings.find("the static load case: the largest strain"), std::string::npos) << warnings;
    }
}

// --compare-linear on the block compressed by 15 % (grid, P1, which holds both homogeneous states
// exactly): report.json simulation.compare_linear holds both models' target displacement and reactions
// and |linear − neo-Hookean| / |neo-Hookean|, checked against the closed forms: linear u = (νε x, νε y,
// −ε z) and the reaction E ε A on the moved and the held face; neo-Hookean the uniaxial state above with
// the reaction P₃₃ A (A = 100 mm², the reference area); the laterally free faces carry no reaction
// (null). The same numbers whichever model the scenario names; the summary lists them.
TEST(StaticLoad, CompareLinearReportsTheClosedFormDifferences) {
  vim::test::TempDir dir("static_compare");
  write_block(dir.path / "block.mha");
  const double eps = 3.0 / kL, l3 = 1.0 - eps, l = lateral(l3), area = 100.0;
  const Eigen::Vector3d lin(kBlockNu * eps * 7, kBlockNu * eps * 3, -eps * 16),
      nh((l - 1) * 7, (l - 1) * 3, (l3 - 1) * 16);
  const double r_lin = kBlockE * eps * area, r_nh = -neo_hookean_piola({{l, l, l3}}, 2) * area;
  ASSERT_GT(std::abs(r_lin - r_nh), 0.1 * r_lin);  // the comparison is not trivial here
  std::string yaml = static_scenario(
      "{type: displacement, region: {box_face: z_max}, value: [0, 0, -3], "
      "components: [z]}");
  for (const bool neo : {true, false}) {
    const std::string name = neo ? "neo" : "linear";
    std::string y = yaml;
    if (neo) y.replace(y.find("material: {"), 11, "material: {model: neo-hookean, ");
    std::ofstream(dir / (name + ".yaml")) << y;
    const auto r = run_pipeline(quote(dir / "block.mha") +
                                " --mesher grid --nodes 300 --export none "
                                "--compare-linear --simulate " +
                                quote(dir / (name + ".yaml")) + " --out " + quote(dir / name));
    ASSERT_EQ(r.code, 0) << r.err;
    nlohmann::json report;
    std::ifstream(dir.path / name / "report.json") >> report;
    const auto& sim = report["simulation"];
    EXPECT_EQ(sim["static_load"]["material_model"], neo ? "neo-hookean" : "linear");
    ASSERT_TRUE(sim.contains("compare_linear")) << name;
    const auto& c = sim["compare_linear"];
    const auto& top = c["targets"]["top"];
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(top["linear"][a].get<double>(), lin[a], 1e-8) << name << " axis " << a;
      EXPECT_NEAR(top["neo-hookean"][a].get<double>(), nh[a], 1e-6 * 16) << name << " axis " << a;
    }
    EXPECT_NEAR(top["relative_difference"].get<double>(), (lin - nh).norm() / nh.norm(), 1e-5) << name;
    ASSERT_EQ(c["reactions"].size(), 4u) << name;
    for (int k = 0; k < 4; ++k) {
      const auto& e = c["reactions"][k];
      EXPECT_EQ(e["condition"], "boundary_conditions[" + std::to_string(k) + "]");
      if (k < 2) {  // x_min, y_min: laterally free, no reaction in either model
        EXPECT_TRUE(e["relative_difference"].is_null()) << name << " " << k;
        continue;
      }
      const double sign = k == 2 ? 1.0 : -1.0;  // the held face pushes up, the moved face down
      EXPECT_NEAR(e["linear"][2].get<double>(), sign * r_lin, 1e-6 * r_lin) << name << " " << k;
      EXPECT_NEAR(e["neo-hookean"][2].get<double>(), sign * r_nh, 1e-3 * r_nh) << name << " " << k;
      EXPECT_NEAR(e["relative_difference"].get<double>(), std::abs(r_lin - r_nh) / r_nh, 2e-3)
          << name << " " << k;
    }
    EXPECT_NE(r.out.find("compare_linear (|linear - neo-hookean| / |neo-hookean|)"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("reaction boundary_conditions[3] box_face z_max"), std::string::npos) << r.out;
  }
}

// --compare-linear with a needle scenario (neo-Hookean in the scenario): report.json's
// simulation.compare_linear holds per step both models' axial forces and target displacements, equal
// to those of two separate runs of the scenario with each model, and the relative differences
// recomputed from them; the summary prints the axial force's.
TEST(StaticLoad, CompareLinearWithANeedleMatchesTwoSeparateRuns) {
  vim::test::TempDir dir("static_compare_needle");
  write_block(dir.path / "block.mha");
  const auto scenario = [&](const std::string& model) {
    const fs::path p = dir / (model + ".yaml");
    std::ofstream(p) << "material: {youngs_modulus: image, poisson_ratio: 0.3, model: " << model
                     << "}\n"
                        "boundary_conditions: [{type: fixed, region: {box_face: z_min}}]\n"
                        "needle: {entry: [5.2, 4.9, 20], direction: [0, 0, -1], depth: 8, steps: 4, "
                        "diameter: 1, friction: {model: stick-slip, max_shear_per_length: 4}}\n"
                        "targets: [{name: side, position: [8, 6, 14]}]\n";
    return p;
  };
  const auto run_one = [&](const fs::path& yaml, const std::string& out, const std::string& extra) {
    const auto r = run_pipeline(quote(dir / "block.mha") + " --mesher grid --nodes 300 --export none " +
                                extra + " --simulate " + quote(yaml) + " --out " + quote(dir / out));
    EXPECT_EQ(r.code, 0) << r.err;
    std::ifstream in(dir.path / out / "report.json");
    return std::make_pair(nlohmann::json::parse(in)["simulation"], r.out);
  };
  const auto [both, summary] = run_one(scenario("neo-hookean"), "both", "--compare-linear");
  const nlohmann::json lin = run_one(scenario("linear"), "lin", "-q").first["needles"][0]["per_step"];
  const nlohmann::json nh = run_one(scenario("neo-hookean"), "nh", "-q").first["needles"][0]["per_step"];
  const nlohmann::json& c = both["compare_linear"];
  ASSERT_TRUE(c.contains("axial_force")) << both.dump();
  const nlohmann::json& f = c["axial_force"]["per_step"];
  double largest = 0.0;
  for (std::size_t k = 0; k < lin["axial_force"].size(); ++k) {
    const double l = lin["axial_force"][k].get<double>(), n = nh["axial_force"][k].get<double>();
    EXPECT_NEAR(f["linear"][k].get<double>(), l, 1e-12 * (1.0 + std::abs(l))) << k;
    EXPECT_NEAR(f["neo-hookean"][k].get<double>(), n, 1e-9 * (1.0 + std::abs(n))) << k;
    if (f["relative_difference"][k].is_number()) {
      EXPECT_NEAR(f["relative_difference"][k].get<double>(), std::abs(l - n) / std::abs(n), 1e-8) << k;
      largest = std::max(largest, std::abs(l - n) / std::abs(n));
    }
  }
  EXPECT_NEAR(c["axial_force"]["largest_relative_difference"].get<double>(), largest, 1e-8);
  EXPECT_GT(largest, 0.0);
  const nlohmann::json& t = c["targets"]["side"]["per_step"];
  const std::size_t last = lin["axial_force"].size() - 1;
  for (int d = 0; d < 3; ++d)
    EXPECT_NEAR(t["linear"][last][d].get<double>(), lin["target_displacement"]["side"][last][d].get<double>(),
                1e-9)
        << d;
  EXPECT_NE(summary.find("axial force:"), std::string::npos) << summary;
}

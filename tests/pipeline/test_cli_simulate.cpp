// The main job through the real CLI: `vim-pipeline IMAGE --simulate SCENARIO --out DIR` on an image
// with an oblique direction and anisotropic spacing. Positions and vectors are checked in world
// coordinates computed here from the image header (independently of the pipeline's transform code);
// figures are checked for content. Also: the README's option and scenario references agree with
// the program (--help, the scenario parser).
#include <gtest/gtest.h>
#include <vtkCell.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/output/png.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

#include "mesh_angles.hpp"
#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;
using vim::test::quote;
using vim::test::run_pipeline;
namespace fs = std::filesystem;

namespace {

Eigen::Matrix3d oblique() {
  const Eigen::Vector3d k = Eigen::Vector3d(1, 2, -2).normalized();
  Eigen::Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  const double t = 0.7;
  return Eigen::Matrix3d::Identity() + std::sin(t) * K + (1 - std::cos(t)) * K * K;
}

// world = origin + D·(idx ⊙ spacing), voxel centres at integer idx.
Eigen::Vector3d world_of_index(const OrientedImage<3>& im, const Eigen::Vector3d& idx) {
  Eigen::Vector3d o, s;
  for (int a = 0; a < 3; ++a) o[a] = im.image.origin[a], s[a] = im.image.spacing[a];
  return o + im.direction * idx.cwiseProduct(s);
}

std::string yaml_vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s.precision(17);
  s << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
  return s.str();
}

vtkSmartPointer<vtkUnstructuredGrid> read_vtu(const fs::path& path) {
  vtkNew<vtkXMLUnstructuredGridReader> r;
  r->SetFileName(path.string().c_str());
  r->Update();
  vtkSmartPointer<vtkUnstructuredGrid> g = r->GetOutput();
  return g;
}

std::vector<std::vector<std::string>> read_csv(const fs::path& path) {
  std::ifstream f(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(f, line)) {
    std::vector<std::string> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) row.push_back(cell);
    rows.push_back(row);
  }
  return rows;
}

// Per-channel variance of the pixels: 0 for a blank image.
double pixel_variance(const Canvas& c) {
  double s = 0, s2 = 0;
  const double n = 3.0 * c.width() * c.height();
  for (int y = 0; y < c.height(); ++y)
    for (int x = 0; x < c.width(); ++x) {
      const Rgb p = c.at(x, y);
      for (double v : {double(p.r), double(p.g), double(p.b)}) s += v, s2 += v * v;
    }
  return s2 / n - (s / n) * (s / n);
}

std::string section(const std::string& text, const std::string& heading) {
  const auto b = text.find(heading);
  if (b == std::string::npos) return {};
  const auto e = text.find("\n## ", b + heading.size());
  return text.substr(b, e == std::string::npos ? std::string::npos : e - b);
}

std::set<std::string> long_options(const std::string& text) {
  std::set<std::string> out;
  const std::regex re("--[a-z][a-z-]*[a-z]");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it)
    out.insert(it->str());
  return out;
}

}  // namespace

TEST(CliSimulate, ObliqueAnisotropicNeedleRunWritesWorldResultsAndFigures) {
  vim::test::TempDir dir("clisim");
  auto im = phantoms::table1(12);  // sphere (2.0) in 1.0; 12³ voxels
  im.image.spacing = {{2.0, 1.5, 2.5}};
  im.image.origin = {{3.0, -1.0, 12.0}};
  im.direction = oblique();
  write_image(im, dir / "in.mha");

  // Needle along the image's first index axis through the middle, from the x_min face; x_max held.
  // (The force's growth with depth is tested on refined meshes in test_simulation.cpp.)
  const Eigen::Vector3d entry_idx(-0.5, 5.5, 5.5), target_idx(8.0, 5.5, 5.5), fixed_idx(11.5, 1.0, 2.0);
  const Eigen::Vector3d entry = world_of_index(im, entry_idx);
  const Eigen::Vector3d dir_w =
      (world_of_index(im, entry_idx + Eigen::Vector3d::UnitX()) - entry).normalized();
  const double extent_x = 12 * 2.0, depth = 0.55 * extent_x;
  const int steps = 6;
  {
    std::ofstream f(dir / "needle.yaml");
    f << "units: {length: mm, modulus: kPa}\n"
         "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.45}\n"
         "boundary_conditions:\n"
         "  - {type: fixed, region: {box_face: x_max}}\n"
         "needle:\n"
         "  entry: "
      << yaml_vec(entry) << "\n  direction: " << yaml_vec(dir_w) << "\n  depth: " << depth
      << "\n  steps: " << steps
      << "\n  diameter: 1.27\n  model: kinematic\n  friction: {model: stick}\n"
         "targets:\n  - {name: ahead, position: "
      << yaml_vec(world_of_index(im, target_idx))
      << "}\n  - {name: corner, position: " << yaml_vec(world_of_index(im, fixed_idx))
      << "}\noutput: {every: 2}\n";
  }
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(quote(dir / "in.mha") + " --nodes 100 --max-iterations 3 --simulate " +
                              quote(dir / "needle.yaml") + " --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;

  for (const char* f : {"mesh.vtu", "mesh.vtk", "mesh.msh", "mesh.inp", "mesh.feb", "simulation.pvd",
                        "needle.csv", "report.json", "steps/step_0000.vtu", "steps/step_0006.vtu",
                        "steps/needle_0000.vtp", "steps/needle_0006.vtp"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;

  // Figures: present, of a plausible size, not blank.
  for (const char* f : {"slice_sagittal", "slice_coronal", "slice_axial", "energy", "needle_force",
                        "target_displacement", "deformed", "needle_path"}) {
    const fs::path p = out / "figures" / (std::string(f) + ".png");
    ASSERT_TRUE(fs::is_regular_file(p)) << p;
    const Canvas c = Canvas::read_png(p);
    EXPECT_GE(c.width(), 100) << f;
    EXPECT_GE(c.height(), 100) << f;
    EXPECT_GT(pixel_variance(c), 1.0) << f << " is blank";
  }

  // needle.csv: the tip follows entry + depth·direction in world coordinates; the axial force grows.
  const auto csv = read_csv(out / "needle.csv");
  ASSERT_EQ(csv.size(), static_cast<std::size_t>(steps + 2));
  const auto& head = csv[0];
  auto col = [&](const std::string& name) {
    const auto it = std::find(head.begin(), head.end(), name);
    EXPECT_NE(it, head.end()) << name;
    return static_cast<std::size_t>(it - head.begin());
  };
  const std::size_t cd = col("depth"), cx = col("tip_x"), cf = col("axial_force"), cad = col("ahead_dx"),
                    cn = col("corner_norm");
  double last_force = 0.0;
  for (int k = 0; k <= steps; ++k) {
    const auto& row = csv[k + 1];
    const double d = std::stod(row[cd]);
    EXPECT_NEAR(d, depth * k / steps, 1e-9 * depth);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::stod(row[cx + a]), entry[a] + d * dir_w[a], 1e-7) << k;
    last_force = std::stod(row[cf]);
    EXPECT_TRUE(std::isfinite(last_force)) << k;
  }
  EXPECT_GT(last_force, 0.0);
  // The target ahead of the tip is pushed forward along the needle (world axes); a point on the
  // fixed face (x_max) does not move.
  const auto& final_row = csv.back();
  const Eigen::Vector3d u_ahead(std::stod(final_row[cad]), std::stod(final_row[cad + 1]),
                                std::stod(final_row[cad + 2]));
  EXPECT_GT(u_ahead.dot(dir_w), 0.7 * u_ahead.norm()) << u_ahead.transpose();
  EXPECT_GT(u_ahead.norm(), 1e-3);
  EXPECT_LT(std::stod(final_row[cn]), 1e-9 * u_ahead.norm() + 1e-12);

  // Step files: the same world points as mesh.vtu; the point of largest displacement moves along the needle.
  const auto mesh = read_vtu(out / "mesh.vtu");
  const auto step = read_vtu(out / "steps" / "step_0006.vtu");
  ASSERT_EQ(step->GetNumberOfPoints(), mesh->GetNumberOfPoints());
  for (vtkIdType i = 0; i < mesh->GetNumberOfPoints(); ++i) {
    double p[3], q[3];
    mesh->GetPoint(i, p);
    step->GetPoint(i, q);
    for (int a = 0; a < 3; ++a) ASSERT_NEAR(p[a], q[a], 1e-9);
  }
  vtkDataArray* u = step->GetPointData()->GetArray("displacement");
  ASSERT_NE(u, nullptr);
  ASSERT_EQ(u->GetNumberOfComponents(), 3);
  for (const char* name : {"strain", "stress", "von_mises", "youngs_modulus"})
    EXPECT_NE(step->GetCellData()->GetArray(name), nullptr) << name;
  ASSERT_NE(mesh->GetCellData()->GetArray("youngs_modulus"), nullptr);
  Eigen::Vector3d umax = Eigen::Vector3d::Zero();
  for (vtkIdType i = 0; i < step->GetNumberOfPoints(); ++i) {
    const double* t = u->GetTuple3(i);
    const Eigen::Vector3d v(t[0], t[1], t[2]);
    if (v.norm() > umax.norm()) umax = v;
  }
  EXPECT_GT(umax.norm(), 0.0);
  EXPECT_GT(umax.dot(dir_w), 0.7 * umax.norm()) << umax.transpose();

  // report.json: the simulation, the exports and the figures are recorded.
  const auto rep = nlohmann::json::parse(vim::test::slurp(out / "report.json"));
  EXPECT_TRUE(rep.contains("simulation"));
  EXPECT_TRUE(rep["timing"].contains("simulate"));
  for (const char* f : {"vtk", "msh", "inp", "feb"})
    EXPECT_EQ(rep["exports"]["files"][f], std::string("mesh.") + f);
  // The exports carry the scenario's Poisson ratio (they wrote 0.49 whatever the scenario said).
  EXPECT_EQ(rep["exports"]["poisson_ratio"].get<double>(), 0.45);
  const std::string inp = vim::test::slurp(out / "mesh.inp");
  EXPECT_NE(inp.find("*Elastic\n"), std::string::npos);
  std::size_t elastic = 0;
  for (std::size_t at = inp.find("*Elastic\n"); at != std::string::npos;
       at = inp.find("*Elastic\n", at + 1)) {
    const std::size_t line = at + 9, comma = inp.find(", ", line);
    EXPECT_EQ(std::stod(inp.substr(comma + 2)), 0.45) << inp.substr(line, 60);  // "E, nu"
    ++elastic;
  }
  EXPECT_GE(elastic, 1u);
  const std::string feb = vim::test::slurp(out / "mesh.feb");
  const std::size_t v = feb.find("<v>");
  ASSERT_NE(v, std::string::npos);
  EXPECT_EQ(std::stod(feb.substr(v + 3)), 0.45) << feb.substr(v, 40);
  EXPECT_TRUE(rep["figures"].contains("energy"));
  EXPECT_TRUE(rep["figures"]["simulation"].contains("needle"));
  std::set<std::string> listed(rep["outputs"].begin(), rep["outputs"].end());
  for (const char* f : {"figures/deformed.png", "figures/needle_force.png", "mesh.feb", "needle.csv"})
    EXPECT_TRUE(listed.count(f)) << f;
}

TEST(CliSimulate, ReadmeOptionTableMatchesHelp) {
  const std::string readme = vim::test::slurp(fs::path(VIM_SOURCE_DIR) / "README.md");
  const std::string table = section(readme, "## Options");
  ASSERT_FALSE(table.empty()) << "README.md has no '## Options' section";
  const auto h = run_pipeline("--help");
  ASSERT_EQ(h.code, 0);
  const std::string help = h.out.substr(0, h.out.find("Outputs ("));  // the option list only
  const auto in_readme = long_options(table), in_help = long_options(help);
  EXPECT_GE(in_help.size(), 15u);
  for (const auto& o : in_help)
    EXPECT_TRUE(in_readme.count(o)) << o << " is in --help but not in README's Options";
  for (const auto& o : in_readme)
    EXPECT_TRUE(in_help.count(o)) << o << " is in README's Options but not in --help";
}

TEST(CliSimulate, ReadmeScenarioReferenceParses) {
  const std::string readme = vim::test::slurp(fs::path(VIM_SOURCE_DIR) / "README.md");
  const std::string sec = section(readme, "## Scenario file");
  const auto b = sec.find("```yaml\n");
  ASSERT_NE(b, std::string::npos) << "README.md's scenario section has no yaml block";
  const auto e = sec.find("```", b + 8);
  const std::string yaml = sec.substr(b + 8, e - b - 8);
  const Scenario sc = parse_scenario_text(yaml, 3, "README.md");
  EXPECT_EQ(sc.boundary_conditions.size(), 8u);
  EXPECT_EQ(sc.labels.size(), 2u);
  ASSERT_EQ(sc.needles.size(), 1u);
  ASSERT_EQ(sc.targets.size(), 2u);
  EXPECT_EQ(sc.targets[1].label, "lesion");  // at a label's centroid (with --labels)
  EXPECT_EQ(sc.nodes.value_or(0), 3000);
  EXPECT_TRUE(sc.needle_refinement.has_value());
  EXPECT_NEAR(sc.needles[0].depth, 40.0, 0);
  EXPECT_EQ(sc.solver_type, "auto");
  // Every top-level key of the reference is one the parser knows (it would have thrown otherwise);
  // and the shipped example parses too.
  EXPECT_NO_THROW(
      read_scenario((fs::path(VIM_SOURCE_DIR) / "examples" / "prostate_needle.yaml").string(), 3));
  EXPECT_NO_THROW(
      read_scenario((fs::path(VIM_SOURCE_DIR) / "examples" / "prostate_labels.yaml").string(), 3));
  const Scenario plan =
      read_scenario((fs::path(VIM_SOURCE_DIR) / "examples" / "prostate_procedure.yaml").string(), 3);
  std::size_t seeds = 0;
  for (const auto& n : plan.needles) seeds += n.seeds.size();
  ASSERT_EQ(plan.needles.size(), 7u);  // a stabilising needle, then six with seeds
  EXPECT_TRUE(plan.needles[0].stay);
  EXPECT_EQ(seeds, 17u);
  ASSERT_TRUE(plan.probe);  // the TRUS probe, moved once between the third and the fourth seed needle
  ASSERT_EQ(plan.probe->motions.size(), 1u);
  EXPECT_DOUBLE_EQ(plan.probe->hold.region.length, 40.0);  // in 40 mm from the perineum face, not to x_max
  EXPECT_EQ(plan.probe->motions[0].after, 4u);
}

// The AMG solver uses Trilinos, which needs MPI initialised even on one process. The CLI runs without
// mpirun; before the fix, `--mesher voxel --simulate` (62k DoFs: AMG by `auto`) aborted in
// MPI_Comm_size. Both meshers with `solver: {type: amg}`, on a small prostate phantom, must finish
// and report the AMG method, with the same target displacement as the direct solver.
TEST(CliSimulate, AmgSolverRunsWithoutAnMpiLauncher) {
  vim::test::TempDir dir("cliamg");
  const fs::path image = dir.path / "prostate.mha", labels = dir.path / "labels.mha";
  const auto made = vim::test::run_command(
      VIM_PHANTOM_EXE, "prostate " + quote(image.string()) + " --size 12 --labels " + quote(labels.string()));
  ASSERT_EQ(made.code, 0) << made.err;
  std::string yaml = vim::test::slurp(fs::path(VIM_SOURCE_DIR) / "examples" / "prostate_needle.yaml");
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
  };
  replace("nodes: 3000", "nodes: 200");
  replace("steps: 36", "steps: 3");
  replace("solver: {type: auto", "solver: {type: SOLVER");
  auto run = [&](const std::string& mesher, const std::string& solver) {
    std::string text = yaml;
    text.replace(text.find("SOLVER"), 6, solver);
    const fs::path scenario = dir.path / ("needle_" + mesher + "_" + solver + ".yaml");
    std::ofstream(scenario) << text;
    const fs::path out = dir.path / ("out_" + mesher + "_" + solver);
    const auto r =
        run_pipeline(quote(image.string()) + " --labels " + quote(labels.string()) + " --mesher " + mesher +
                     " --quiet --simulate " + quote(scenario.string()) + " --out " + quote(out.string()));
    EXPECT_EQ(r.code, 0) << mesher << "/" << solver << ": " << r.err;
    std::ifstream f(out / "report.json");
    nlohmann::json report;
    if (f) f >> report;
    return report;
  };
  for (const std::string mesher : {"vim", "voxel"}) {
    const auto amg = run(mesher, "amg");
    const auto direct = run(mesher, "direct");
    ASSERT_TRUE(amg.contains("simulation")) << mesher;
    ASSERT_TRUE(direct.contains("simulation")) << mesher;
    EXPECT_EQ(amg["simulation"]["needles"][0]["solver"]["method"], "cg+amg") << mesher;
    EXPECT_EQ(direct["simulation"]["needles"][0]["solver"]["method"], "cholmod") << mesher;
    const double ua = amg["simulation"]["final_displacement_lesion"].get<double>();
    const double ud = direct["simulation"]["final_displacement_lesion"].get<double>();
    EXPECT_GT(ud, 0.0) << mesher;
    EXPECT_NEAR(ua, ud, 1e-6 * ud) << mesher;
  }
}

// mesh.needle_refinement through the CLI on an oblique image: the VIM mesh's cells within the
// refinement radius of the needle path (world coordinates, from mesh.vtu) are smaller than the others,
// by clearly more than without the key; the report records it; --sizing with it is refused.
TEST(CliSimulate, NeedleRefinementRefinesTheMeshAlongThePath) {
  vim::test::TempDir dir("clirefine");
  auto im = phantoms::table1(16);
  im.image.spacing = {{1.5, 1.5, 1.5}};
  im.image.origin = {{3.0, -1.0, 12.0}};
  im.direction = oblique();
  write_image(im, dir / "in.mha");
  const Eigen::Vector3d entry_idx(-0.5, 4.0, 11.0);
  const Eigen::Vector3d entry = world_of_index(im, entry_idx);
  const Eigen::Vector3d dir_w =
      (world_of_index(im, entry_idx + Eigen::Vector3d::UnitX()) - entry).normalized();
  const double depth = 15.0, radius = 4.0;
  auto scenario = [&](const std::string& mesh_line) {
    std::ostringstream f;
    f << "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.3}\n"
      << mesh_line
      << "boundary_conditions:\n  - {type: fixed, region: {box_face: x_max}}\n"
         "needle: {entry: "
      << yaml_vec(entry) << ", direction: " << yaml_vec(dir_w) << ", depth: " << depth
      << ", steps: 1, diameter: 1.27, friction: {model: stick}}\noutput: {every: 0}\n";
    return f.str();
  };
  auto near_far_volume =
      [&](const fs::path& out) {  // mean tet volume within `radius` of the path / elsewhere
        const auto g = read_vtu(out / "mesh.vtu");
        double near = 0, far = 0;
        int nn = 0, nf = 0;
        for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
          vtkCell* cell = g->GetCell(c);
          std::array<Eigen::Vector3d, 4> x;
          for (int k = 0; k < 4; ++k) g->GetPoint(cell->GetPointId(k), x[k].data());
          const double v = std::abs((x[1] - x[0]).cross(x[2] - x[0]).dot(x[3] - x[0])) / 6.0;
          const Eigen::Vector3d m = (x[0] + x[1] + x[2] + x[3]) / 4.0;
          const double s = std::clamp((m - entry).dot(dir_w), 0.0, depth);
          if ((m - entry - s * dir_w).norm() < radius)
            near += v, ++nn;
          else
            far += v, ++nf;
        }
        EXPECT_GT(nn, 0);
        return (near / std::max(nn, 1)) / (far / std::max(nf, 1));
      };
  std::ofstream(dir / "plain.yaml") << scenario("");
  std::ofstream(dir / "refined.yaml")
      << scenario("mesh: {needle_refinement: {size_ratio: 0.5, radius: " + std::to_string(radius) + "}}\n");
  const std::string common = quote(dir / "in.mha") + " --nodes 400 --max-iterations 8 --simulate ";
  const auto plain = run_pipeline(common + quote(dir / "plain.yaml") + " --out " + quote(dir / "plain"));
  ASSERT_EQ(plain.code, 0) << plain.err;
  const auto refined =
      run_pipeline(common + quote(dir / "refined.yaml") + " --out " + quote(dir / "refined"));
  ASSERT_EQ(refined.code, 0) << refined.err;
  const double r_plain = near_far_volume(dir.path / "plain"),
               r_refined = near_far_volume(dir.path / "refined");
  std::printf("near/far mean tet volume: plain VIM %.3f, needle refinement %.3f\n", r_plain, r_refined);
  EXPECT_LT(r_refined, 0.7 * r_plain);
  EXPECT_LT(r_refined, 0.7);
  const auto rep = nlohmann::json::parse(vim::test::slurp(dir.path / "refined" / "report.json"));
  EXPECT_DOUBLE_EQ(rep["needle_refinement"]["size_ratio"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(rep["needle_refinement"]["peak_density"].get<double>(), 32.0);
  EXPECT_TRUE(rep["timing"].contains("sizing"));

  write_image(im, dir / "density.mha");
  const auto both = run_pipeline(common + quote(dir / "refined.yaml") + " --sizing " +
                                 quote(dir / "density.mha") + " --out " + quote(dir / "both"));
  EXPECT_NE(both.code, 0);
  EXPECT_NE(both.err.find("mesh.needle_refinement"), std::string::npos) << both.err;
  EXPECT_FALSE(fs::exists(dir.path / "both" / "mesh.vtu"));
}

// A degree-1 (P1) simulation of nearly incompressible tissue (poisson_ratio >= 0.4) warns about
// volumetric locking on stderr and in report.json, naming the fix; degree 2, a lower Poisson ratio
// and the voxel reference (hexahedra, not P1 tetrahedra) do not warn.
TEST(CliSimulate, LinearElementsWarnAboutLockingForNearlyIncompressibleTissue) {
  vim::test::TempDir dir("clilock");
  auto im = phantoms::table1(12);
  write_image(im, dir / "in.mha");
  auto scenario = [&](const std::string& name, double nu) {
    std::ofstream(dir / name) << "material: {youngs_modulus: image, poisson_ratio: " << nu
                              << "}\nboundary_conditions:\n  - {type: fixed, region: {box_face: z_max}}\n"
                                 "needle: {entry: [1.5, 1.5, 0], direction: [0, 0, 1], depth: 1.0, steps: 1, "
                                 "diameter: 0.1, friction: {model: stick}}\n"
                                 "output: {every: 0}\n";
    return quote(dir / name);
  };
  const std::string nearly = scenario("nu045.yaml", 0.45), compressible = scenario("nu03.yaml", 0.3);
  struct Case {
    std::string args, out;
    bool warns;
  };
  const std::vector<Case> cases = {{"--simulate " + nearly, "p1", true},
                                   {"--simulate " + nearly + " --mesher grid", "p1grid", true},
                                   {"--simulate " + nearly + " --degree 2", "p2", false},
                                   {"--simulate " + compressible, "p1nu03", false},
                                   {"--simulate " + nearly + " --mesher voxel", "voxel", false}};
  for (const Case& c : cases) {
    const auto r = run_pipeline(quote(dir / "in.mha") + " --nodes 64 --max-iterations 2 --export none " +
                                c.args + " --out " + quote(dir / c.out));
    ASSERT_EQ(r.code, 0) << c.out << ": " << r.err;
    const auto rep = nlohmann::json::parse(vim::test::slurp(dir.path / c.out / "report.json"));
    const bool in_stderr = r.err.find("P1 tetrahedra lock for poisson_ratio >= 0.4") != std::string::npos;
    EXPECT_EQ(in_stderr, c.warns) << c.out << ": " << r.err;
    // The needle also strains the tissue beyond 10% (the small-strain warning): only the locking warning
    // counts.
    std::vector<std::string> locking;
    if (rep.contains("warnings"))
      for (const auto& w : rep["warnings"])
        if (w.get<std::string>().find("lock for poisson_ratio") != std::string::npos)
          locking.push_back(w.get<std::string>());
    ASSERT_EQ(!locking.empty(), c.warns) << c.out;
    if (c.warns) {
      ASSERT_EQ(locking.size(), 1u) << c.out;
      const std::string w = locking[0];
      EXPECT_NE(w.find("nu045.yaml: material.poisson_ratio = 0.45"), std::string::npos) << w;
      EXPECT_NE(w.find("set mesh.degree: 2"), std::string::npos) << w;
    }
  }
  // --quiet keeps stderr free of it, the report still records it.
  const auto q = run_pipeline(quote(dir / "in.mha") +
                              " --nodes 64 --max-iterations 2 --export none --quiet --simulate " + nearly +
                              " --out " + quote(dir / "quiet"));
  ASSERT_EQ(q.code, 0) << q.err;
  EXPECT_EQ(q.err.find("lock"), std::string::npos) << q.err;
  EXPECT_NE(
      nlohmann::json::parse(vim::test::slurp(dir.path / "quiet" / "report.json"))["warnings"].dump().find(
          "lock for poisson_ratio"),
      std::string::npos);
  // A 2D run names the element it means: plane-strain P1 triangles.
  write_image(phantoms::two_inclusions(30), dir / "in2.mha");
  std::ofstream(dir / "nu045_2d.yaml")
      << "material: {youngs_modulus: image, poisson_ratio: 0.45}\n"
         "boundary_conditions:\n  - {type: fixed, region: {box_face: x_max}}\n"
         "needle: {entry: [-30, 3], direction: [1, 0], depth: 10, steps: 1, diameter: 1, friction: {model: "
         "stick}}\n"
         "output: {every: 0}\n";
  const auto two =
      run_pipeline(quote(dir / "in2.mha") + " --nodes 64 --max-iterations 2 --export none --simulate " +
                   quote(dir / "nu045_2d.yaml") + " --out " + quote(dir / "p1_2d"));
  ASSERT_EQ(two.code, 0) << two.err;
  EXPECT_NE(two.err.find("P1 triangles (plane strain) lock for poisson_ratio >= 0.4"), std::string::npos)
      << two.err;
  EXPECT_EQ(two.err.find("tetrahedra"), std::string::npos) << two.err;
}

// The scenario's mesh keys apply unless the same option is on the command line: mesh.min_dihedral
// bounds every element of the simulated mesh (smallest dihedral angle from the written points), and
// --min-dihedral overrides it; mesh.lambda likewise.
TEST(CliSimulate, ScenarioMeshKeysApplyUnlessGivenOnTheCommandLine) {
  vim::test::TempDir dir("climeshkeys");
  write_image(phantoms::table1(20), dir / "in.mha");
  std::ofstream(dir / "s.yaml") << "material: {youngs_modulus: image, poisson_ratio: 0.3}\n"
                                   "mesh: {nodes: 343, lambda: 0.6, min_dihedral: 20}\n"
                                   "boundary_conditions:\n  - {type: fixed, region: {box_face: z_max}}\n"
                                   "needle: {entry: [1.5, 1.5, 0], direction: [0, 0, 1], depth: 1.0, steps: "
                                   "1, diameter: 0.1, friction: {model: stick}}\n"
                                   "output: {every: 0}\n";
  const std::string common =
      quote(dir / "in.mha") + " --max-iterations 4 --export none -q --simulate " + quote(dir / "s.yaml");
  const auto a = run_pipeline(common + " --out " + quote(dir / "scenario"));
  ASSERT_EQ(a.code, 0) << a.err;
  const auto b = run_pipeline(common + " --min-dihedral 0 --lambda 0.5 --out " + quote(dir / "cli"));
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ra = nlohmann::json::parse(vim::test::slurp(dir.path / "scenario" / "report.json"));
  const auto rb = nlohmann::json::parse(vim::test::slurp(dir.path / "cli" / "report.json"));
  EXPECT_EQ(ra["options"]["min_dihedral_deg"].get<double>(), 20.0);
  EXPECT_EQ(ra["options"]["lambda"].get<double>(), 0.6);
  EXPECT_EQ(ra["options"]["nodes"].get<long>(), 343);
  EXPECT_EQ(rb["options"]["min_dihedral_deg"].get<double>(), 0.0);
  EXPECT_EQ(rb["options"]["lambda"].get<double>(), 0.5);
  EXPECT_GE(vim::test::smallest_angle_deg(read_vtu(dir.path / "scenario" / "mesh.vtu"), 3), 20.0 - 1e-9);
  EXPECT_LT(vim::test::smallest_angle_deg(read_vtu(dir.path / "cli" / "mesh.vtu"), 3), 20.0)
      << "the bound would not be active";
}

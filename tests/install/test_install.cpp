// The installed tree and the version number.
// Truths: the version set in CMake's project(VERSION) (passed here by CMake itself, not through the
// generated header); the CLI run from the installed tree on the same image and scenario (a separate
// program that reads its own options) for the downstream project's numbers; and, for the mesher linked
// through pkg-config, what any tiling of the image box satisfies (element volumes sum to the box's,
// every voxel centre lies in exactly one element, the quality bound, E never rising).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "run_cli.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using vim::test::quote;
using vim::test::run_command;
using vim::test::slurp;

namespace {

const std::string kVersion = VIM_CMAKE_PROJECT_VERSION;

// "key value" lines as printed by the downstream programs.
std::map<std::string, std::string> key_values(const std::string& text) {
  std::map<std::string, std::string> kv;
  std::istringstream in(text);
  std::string key, value;
  while (in >> key >> value) kv[key] = value;
  return kv;
}

nlohmann::json read_json(const fs::path& p) { return nlohmann::json::parse(slurp(p)); }

// A small Table I phantom and a needle scenario on it (no `mesh:` section: the node budget is the
// command line's). The phantom's box is [-1.5, 1.5]^3.
void write_inputs(const fs::path& dir, const fs::path& phantom_exe) {
  const auto made =
      run_command(phantom_exe.string(), "table1 " + quote((dir / "table1.mha").string()) + " --size 16");
  ASSERT_EQ(made.code, 0) << made.err;
  std::ofstream(dir / "needle.yaml") << "material: {youngs_modulus: image, poisson_ratio: 0.45}\n"
                                        "boundary_conditions:\n  - {type: fixed, region: {box_face: z_min}}\n"
                                        "needle: {entry: [0.1, 0.2, 1.5], direction: [0, 0, -1], depth: 1.2, "
                                        "steps: 3, diameter: 0.1, friction: {model: stick}}\n";
}

}  // namespace

TEST(Version, EveryProgramAndFileReportsTheCMakeProjectVersion) {
  const auto dir = vim::test::scratch_dir("install", "version");
  EXPECT_EQ(run_command(VIM_PIPELINE_EXE, "--version").out, "vim-pipeline " + kVersion + "\n");
  EXPECT_EQ(run_command(VIM_PHANTOM_EXE, "--version").out, "vim-make-phantom " + kVersion + "\n");

  const auto made = run_command(VIM_PHANTOM_EXE, "table1 " + quote((dir / "t.mha").string()) + " --size 12");
  ASSERT_EQ(made.code, 0) << made.err;
  const auto run =
      run_command(VIM_PIPELINE_EXE, quote((dir / "t.mha").string()) + " --nodes 27 --max-iterations 1 " +
                                        "--export none -q --out " + quote((dir / "out").string()));
  ASSERT_EQ(run.code, 0) << run.err;
  const auto report = read_json(dir / "out" / "report.json");
  EXPECT_EQ(report["tool"]["name"], "vim-pipeline");
  EXPECT_EQ(report["tool"]["version"], kVersion);

  // The citation and the changelog's latest release carry the same number.
  const std::string citation = slurp(fs::path(VIM_SOURCE_DIR) / "CITATION.cff");
  EXPECT_NE(citation.find("\nversion: \"" + kVersion + "\"\n"), std::string::npos);
  const std::string changelog = slurp(fs::path(VIM_SOURCE_DIR) / "CHANGELOG.md");
  const auto first_release = changelog.find("\n## [", changelog.find("\n## [Unreleased]") + 1);
  ASSERT_NE(first_release, std::string::npos);
  EXPECT_EQ(changelog.substr(first_release, 6 + kVersion.size()), "\n## [" + kVersion + "]");
}

// cmake --install into a temporary prefix; examples/downstream configured against it with
// CMAKE_PREFIX_PATH, built, and run: its mesh and needle forces equal those of the installed CLI.
TEST(Install, DownstreamProjectBuildsAndRunsAgainstTheInstalledTree) {
  const auto dir = vim::test::scratch_dir("install", "downstream");
  const fs::path prefix = dir / "prefix", build = dir / "build";
  const std::string cmake = VIM_CMAKE_COMMAND;
  const auto installed =
      run_command(cmake, "--install " + quote(VIM_BUILD_DIR) + " --prefix " + quote(prefix.string()));
  ASSERT_EQ(installed.code, 0) << installed.out << installed.err;
  const fs::path lib = prefix / VIM_INSTALL_LIBDIR;
  for (const fs::path& f :
       {prefix / "bin" / "vim-pipeline", prefix / "bin" / "vim-make-phantom",
        prefix / "include" / "vim" / "vim.hpp", prefix / "include" / "vim" / "version.hpp",
        prefix / "include" / "vim" / "pipeline" / "simulation" / "simulation.hpp", lib / "libvim_mesher.a",
        lib / "libvim_fem.a", lib / "libvim_pipeline.a",
        lib / "cmake" / "vim_pipeline" / "vim_pipelineConfig.cmake",
        lib / "cmake" / "vim_pipeline" / "vim_pipelineConfigVersion.cmake",
        lib / "pkgconfig" / "vim-mesher.pc"})
    EXPECT_TRUE(fs::exists(f)) << f;
  EXPECT_NE(slurp(lib / "pkgconfig" / "vim-mesher.pc").find("Version: " + kVersion), std::string::npos);

  std::string configure = "-S " + quote(std::string(VIM_SOURCE_DIR) + "/examples/downstream") + " -B " +
                          quote(build.string()) + " -DCMAKE_PREFIX_PATH=" + quote(prefix.string()) +
                          " -DCMAKE_CXX_COMPILER=" + quote(VIM_CXX_COMPILER);
  if (!std::string(VIM_DOWNSTREAM_LINKER_FLAGS).empty())
    configure += " -DCMAKE_EXE_LINKER_FLAGS=" + quote(VIM_DOWNSTREAM_LINKER_FLAGS);
  if (!std::string(VIM_CXX_COMPILER_LAUNCHER).empty())
    configure += " -DCMAKE_CXX_COMPILER_LAUNCHER=" + quote(VIM_CXX_COMPILER_LAUNCHER);
  const auto configured = run_command(cmake, configure);
  ASSERT_EQ(configured.code, 0) << configured.out << configured.err;
  const auto built = run_command(cmake, "--build " + quote(build.string()) + " -j 2");
  ASSERT_EQ(built.code, 0) << built.out << built.err;

  // The mesher through pkg-config: a tiling of [0, 3]^3 that holds all 24^3 voxel centres once.
  const auto box = run_command((build / "mesh_box").string(), "64");
  ASSERT_EQ(box.code, 0) << box.err;
  auto kb = key_values(box.out);
  EXPECT_NEAR(std::stod(kb["volume"]), 27.0, 1e-9);
  EXPECT_EQ(std::stol(kb["voxels"]), 24L * 24 * 24);
  EXPECT_LE(std::stod(kb["max_dihedral"]), 150.0 + 1e-9);
  EXPECT_LT(std::stod(kb["energy_last"]), std::stod(kb["energy_first"]));

  // The CMake package: VIM + needle simulation, against the installed vim-pipeline on the same input.
  write_inputs(dir, prefix / "bin" / "vim-make-phantom");
  const std::string image = quote((dir / "table1.mha").string()),
                    scenario = quote((dir / "needle.yaml").string());
  const auto ours = run_command((build / "mesh_and_simulate").string(), image + " " + scenario + " 125");
  ASSERT_EQ(ours.code, 0) << ours.err;
  const auto cli = run_command((prefix / "bin" / "vim-pipeline").string(),
                               image + " --nodes 125 --simulate " + scenario + " --export none -q --out " +
                                   quote((dir / "cli").string()));
  ASSERT_EQ(cli.code, 0) << cli.err;
  const auto report = read_json(dir / "cli" / "report.json");
  auto k = key_values(ours.out);
  EXPECT_EQ(k["version"], kVersion);
  EXPECT_EQ(std::stol(k["nodes"]), report["mesh"]["nodes"].get<long>());
  EXPECT_EQ(std::stol(k["elements"]), report["mesh"]["elements"].get<long>());
  EXPECT_EQ(std::stol(k["iterations"]), report["optimization"]["iterations"].get<long>());
  const double energy = report["optimization"]["history"].back()["E"].get<double>();
  EXPECT_NEAR(std::stod(k["energy"]), energy, 1e-12 * std::abs(energy));
  const auto& needle = report["simulation"]["needles"][0];
  EXPECT_EQ(std::stol(k["steps"]), static_cast<long>(needle["per_step"]["depth"].size()) - 1);
  EXPECT_NEAR(std::stod(k["depth"]), 1.2, 1e-12);
  const double axial = needle["final"]["axial_force"].get<double>();
  const double lateral = needle["final"]["lateral_force"].get<double>();
  EXPECT_GT(axial, 0.0);  // a needle pushed into tissue meets resistance
  EXPECT_NEAR(std::stod(k["axial_force"]), axial, 1e-9 * std::abs(axial));
  EXPECT_NEAR(std::stod(k["lateral_force"]), lateral, 1e-9 * std::abs(axial));
}

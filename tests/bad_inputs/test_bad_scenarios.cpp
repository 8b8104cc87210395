// Bad --simulate scenarios through the real CLI: exit code 1, one `vim-pipeline: error:`
// line naming the key/value, and nothing left in --out. The unmodified base scenario must succeed,
// so every failure below is caused by its one change.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>
#include <string>
#include <vim/pipeline/image/image_io.hpp>

using namespace vim;
using namespace vim::pipeline;
namespace fs = std::filesystem;

namespace {

const char* kBase = R"(material: {youngs_modulus: image, poisson_ratio: 0.45}
boundary_conditions:
  - {type: fixed, region: {box_face: x_max}}
  - {type: fixed, region: {cylinder: {center: [0, -6, 0], axis: [1, 0, 0], radius: 2}}}
needle:
  entry: [-8, 0, 1]
  direction: [1, 0, 0]
  depth: 8
  steps: 2
  diameter: 1
  friction: {model: stick}
targets:
  - {name: lesion, position: [2, 0, 1]}
output: {every: 1}
)";

struct CliRun {
  int code = -1;
  std::string err;
};

class BadScenario : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::replace(test.begin(), test.end(), '/', '_');  // a parameterized test's name holds '/'
    dir_ = fs::temp_directory_path() / ("vim_bad_scen_" + std::to_string(::getpid()) + "_" + test);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    image_ = (dir_ / "block.mha").string();
    write_block(image_, 10.0f);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // 16 x 12 x 12 voxels of 1 mm, box [-8,8] x [-6,6] x [-6,6].
  static void write_block(const std::string& path, float value, float special = 0.0f) {
    OrientedImage<3> img;
    img.image = Image<3>({{16, 12, 12}}, {{1, 1, 1}}, {{-7.5, -5.5, -5.5}}, value);
    if (special != 0.0f) img.image.data[100] = special;
    write_image<3>(img, path);
  }

  // extra: more command-line arguments (e.g. --fit-forces FILE).
  CliRun run(const std::string& yaml, const std::string& image = "", const std::string& extra = "") {
    const fs::path scen = dir_ / "s.yaml", out = dir_ / "out", err = dir_ / "err.txt";
    fs::remove_all(out);
    std::ofstream(scen) << yaml;
    const std::string cmd = std::string(VIM_PIPELINE_EXE) + " " + (image.empty() ? image_ : image) +
                            " --simulate " + scen.string() + extra +
                            " --mesher grid --nodes 300 --export none -q --out " + out.string() + " 2> " +
                            err.string() + " > /dev/null";
    CliRun r;
    const int s = std::system(cmd.c_str());
    r.code = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
    std::ifstream e(err);
    std::stringstream ss;
    ss << e.rdbuf();
    r.err = ss.str();
    return r;
  }

  bool out_is_empty() const {
    const fs::path out = dir_ / "out";
    return !fs::exists(out) || fs::is_empty(out);
  }

  void expect_error(const std::string& yaml, const std::vector<std::string>& parts,
                    const std::string& image = "", const std::string& extra = "") {
    const CliRun r = run(yaml, image, extra);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(r.err.rfind("vim-pipeline: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line only: " << r.err;
    for (const auto& p : parts)
      EXPECT_NE(r.err.find(p), std::string::npos) << "message lacks '" << p << "': " << r.err;
    EXPECT_TRUE(out_is_empty()) << "files left in --out";
  }

  static std::string with(const std::string& from, const std::string& to) {
    std::string s = kBase;
    const auto k = s.find(from);
    EXPECT_NE(k, std::string::npos) << from;
    if (k != std::string::npos) s.replace(k, from.size(), to);
    return s;
  }

  fs::path dir_;
  std::string image_;
};

// The base scenario's needle (lines 5-11) and a probe with a procedure that moves it, to replace it.
const char* kNeedle =
    "needle:\n  entry: [-8, 0, 1]\n  direction: [1, 0, 0]\n  depth: 8\n  steps: 2\n  diameter: 1\n"
    "  friction: {model: stick}\n";
std::string probe_procedure(const std::string& region, const std::string& support,
                            const std::string& action) {
  return "probe: {region: " + region + ", support: " + support + "}\nprocedure:\n  - probe: " + action + "\n";
}
const std::string kProbeCylinder = "{cylinder: {center: [0, 3, 0], axis: [1, 0, 0], radius: 1.5}}";
const std::string kProbeSupport = "{elastic: {stiffness: 20}}";

// One edit of the base scenario each (from → to), and the words its one-line error must hold.
struct Edit {
  const char* name;
  std::string from, to;
  std::vector<std::string> expected;
};

const Edit kEdits[] = {
    {"MissingKey", "  diameter: 1\n", "", {"s.yaml", "missing key 'needle.diameter'"}},
    {"UnknownKey",
     "  steps: 2\n",
     "  steps: 2\n  speed: 3\n",
     {"s.yaml:10:", "unknown key 'needle.speed'", "valid keys", "direction"}},
    {"WrongType", "depth: 8", "depth: deep", {"s.yaml:8:", "needle.depth must be a number", "'deep'"}},
    {"EntryOutsideTheImageBox",
     "entry: [-8, 0, 1]",
     "entry: [-12, 0, 1]",
     {"needle.entry [-12, 0, 1] is outside the image box", "[-8, -6, -6] .. [8, 6, 6]"}},
    {"ZeroDirection",
     "direction: [1, 0, 0]",
     "direction: [0, 0, 0]",
     {"needle.direction must be a non-zero vector"}},
    {"NonPositiveDepth", "depth: 8", "depth: 0", {"needle.depth must be > 0, got 0"}},
    {"NonPositiveSteps", "steps: 2", "steps: -3", {"needle.steps must be > 0, got -3"}},
    {"NonPositiveDiameter", "diameter: 1", "diameter: 0", {"needle.diameter must be > 0, got 0"}},
    // The needle runs along x through a 16 x 12 x 12 mm box: 12 mm across it.
    {"DiameterLargerThanTheImageBox",
     "diameter: 1",
     "diameter: 13",
     {"s.yaml:6:", "needle.diameter = 13 is larger than the image box",
      "narrowest width perpendicular to the needle's direction is 12"}},
    {"NegativeCuttingForce",
     "  diameter: 1\n",
     "  diameter: 1\n  cutting_force: -2\n",
     {"s.yaml:11:", "needle.cutting_force must be a finite force >= 0, got -2"}},
    // Stick-slip is the default friction and its limit has no default.
    {"StickSlipLimitMissing",
     "  friction: {model: stick}\n",
     "",
     {"s.yaml:6:", "missing key 'needle.friction.max_shear_per_length'", "stick-slip is the default"}},
    {"BoxFaceThatDoesNotExist",
     "box_face: x_max",
     "box_face: top",
     {"s.yaml:3:", "box_face = 'top'", "x_min, x_max, y_min, y_max, z_min, z_max"}},
    {"TargetOutsideTheDomain",
     "position: [2, 0, 1]",
     "position: [2, 0, 9]",
     {"target 'lesion' position [2, 0, 9] is outside the image box"}},
    {"NoFixedBoundaryIsSingular",
     "  - {type: fixed, region: {box_face: x_max}}\n  - {type: fixed, region: {cylinder: "
     "{center: [0, -6, 0], axis: [1, 0, 0], radius: 2}}}\n",
     "  - {type: pressure, region: {box_face: x_max}, value: 1}\n",
     {"boundary_conditions has no 'fixed' or 'displacement' condition", "singular"}},
    {"PoissonRatioHalf",
     "poisson_ratio: 0.45",
     "poisson_ratio: 0.5",
     {"s.yaml:1:", "material.poisson_ratio = 0.5", "< 0.5"}},
    {"UnknownMaterialModel",
     "poisson_ratio: 0.45",
     "poisson_ratio: 0.45, model: mooney",
     {"s.yaml:1:", "material.model = 'mooney' is not valid", "linear, neo-hookean"}},
    {"RegionThatSelectsNoNode",
     "center: [0, -6, 0], axis: [1, 0, 0], radius: 2",
     "center: [0, -30, 0], axis: [1, 0, 0], radius: 2",
     {"s.yaml:4:", "boundary_conditions[1]", "selects no mesh node"}},
    {"FrictionWithTheForceModel",
     "  diameter: 1\n",
     "  diameter: 1\n  model: force\n  tip_force: 5\n",
     {"needle.friction applies only to needle model 'kinematic'"}},
    {"FlexibleNeedleWithoutModulus",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 0, inner_diameter: 0.6}\n",
     {"s.yaml:11:", "needle.flexible.youngs_modulus must be > 0, got 0"}},
    {"FlexibleNeedleBoreWiderThanTheTube",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8, inner_diameter: 1}\n",
     {"s.yaml:11:", "needle.flexible.inner_diameter = 1", "less than the needle's diameter 1"}},
    {"FlexibleNeedleUnknownKey",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8, stiffness: 3}\n",
     {"s.yaml:11:", "unknown key 'needle.flexible.stiffness'", "inner_diameter"}},
    {"FlexibleNeedleHolderInsideTheImage",
     "entry: [-8, 0, 1]\n  direction: [1, 0, 0]\n  depth: 8\n  steps: 2\n  diameter: 1\n",
     "entry: [-6, 0, 1]\n  direction: [1, 0, 0]\n  depth: 8\n  steps: 2\n  diameter: 1\n"
     "  flexible: {youngs_modulus: 2.0e+8, free_length: 3}\n",
     {"s.yaml:11:", "needle.flexible.free_length = 3", "would run 2 through the image box",
      "the entry must lie on the image's surface"}},
    {"HolderOffsetAlongTheNeedle",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8, base_offset: [0.5, 0.2, 0]}\n",
     {"s.yaml:11:", "needle.flexible.base_offset [0.5, 0.2, 0]",
      "must be normal to the needle's direction [1, 0, 0]", "its component along it is 0.5"}},
    {"BevelSideAlongTheNeedle",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8}\n  bevel: {angle: 30, side: [1, 1, 0]}\n",
     {"s.yaml:12:", "needle.bevel.side", "must be normal to the needle's direction [1, 0, 0]"}},
    {"RotationBeyondTheDepth",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8}\n  bevel: {angle: 30, side: [0, 1, 0]}\n"
     "  rotations: [{depth: 9, angle: 180}]\n",
     {"s.yaml:13:", "needle.rotations[0].depth = 9 must lie in (0, 8]"}},
    {"RotationAtZeroDepth",
     "  diameter: 1\n",
     "  diameter: 1\n  flexible: {youngs_modulus: 2.0e+8}\n  bevel: {angle: 30, side: [0, 1, 0]}\n"
     "  rotations: [{depth: 0, angle: 180}]\n",
     {"s.yaml:13:", "needle.rotations[0].depth = 0 must lie in (0, 8]"}},
    {"BevelOnARigidNeedle",
     "  diameter: 1\n",
     "  diameter: 1\n  bevel: {angle: 30, side: [0, 1, 0]}\n",
     {"s.yaml:11:", "needle.bevel needs needle.flexible"}},
    {"SampleSpacingTooSmall",
     "  diameter: 1\n",
     "  diameter: 1\n  sample_spacing: 1.0e-8\n",
     {"needle.sample_spacing", "more than 100000 shaft points"}},
    {"ProbeActionWithoutAProbe",
     kNeedle,
     "procedure:\n  - probe: {translate: [1, 0, 0], steps: 2}\n",
     {"s.yaml:6:", "procedure[0].probe: the scenario has no 'probe' to move"}},
    {"ProbeActionWithTranslateAndRotate",
     kNeedle,
     probe_procedure(kProbeCylinder, kProbeSupport, "{translate: [1, 0, 0], rotate: 5, steps: 2}"),
     {"s.yaml:7:", "procedure[0].probe: give either translate or rotate, not both"}},
    {"ProbeActionWithZeroSteps",
     kNeedle,
     probe_procedure(kProbeCylinder, kProbeSupport, "{translate: [1, 0, 0], steps: 0}"),
     {"s.yaml:7:", "procedure[0].probe.steps must be in 1..1000000, got 0"}},
    {"ProbeActionWithANonNumericAngle",
     kNeedle,
     probe_procedure(kProbeCylinder, kProbeSupport, "{rotate: ten, steps: 2}"),
     {"s.yaml:7:", "procedure[0].probe.rotate must be a number, got 'ten'"}},
    {"ProbeActionWithANonNumericTranslation",
     kNeedle,
     probe_procedure(kProbeCylinder, kProbeSupport, "{translate: [1, x, 0], steps: 2}"),
     {"s.yaml:7:", "procedure[0].probe.translate[1] must be a number, got 'x'"}},
    {"ProbeOnASphere",
     kNeedle,
     probe_procedure("{sphere: {center: [0, 3, 0], radius: 1.5}}", kProbeSupport, "{rotate: 5, steps: 2}"),
     {"s.yaml:5:", "probe.region must be a cylinder (its axis is the probe's axis)"}},
    {"ProbeHeldByItsNodes",
     kNeedle,
     probe_procedure(kProbeCylinder, "nodes", "{rotate: 5, steps: 2}"),
     {"s.yaml:5:", "probe.support must be an elastic foundation"}},
    // Only the x component of one face held: the body can still slide along y and z and rotate about x.
    {"ConditionsThatLeaveARigidMotionFree",
     "  - {type: fixed, region: {box_face: x_max}}\n  - {type: fixed, region: {cylinder: "
     "{center: [0, -6, 0], axis: [1, 0, 0], radius: 2}}}\n",
     "  - {type: fixed, region: {box_face: x_max}, components: [x]}\n",
     {"s.yaml:3:", "boundary_conditions:", "rigid-body motion free"}},
};

// The edit's name in test listings (instead of its bytes).
void PrintTo(const Edit& edit, std::ostream* os) { *os << edit.name; }

class BadScenarioEdit : public BadScenario, public ::testing::WithParamInterface<Edit> {};

}  // namespace

TEST_P(BadScenarioEdit, IsRefused) {
  expect_error(with(GetParam().from, GetParam().to), GetParam().expected);
}

INSTANTIATE_TEST_SUITE_P(BadScenario, BadScenarioEdit, ::testing::ValuesIn(kEdits),
                         [](const ::testing::TestParamInfo<Edit>& info) {
                           return std::string(info.param.name);
                         });

TEST_F(BadScenario, BaseScenarioRuns) {
  const CliRun r = run(kBase);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"mesh.vtu", "report.json", "needle.csv", "simulation.pvd", "steps/step_0002.vtu"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
}

// The probe edits' scenario without its one fault runs and writes the probe's outputs.
TEST_F(BadScenario, ProbeProcedureRuns) {
  const CliRun r =
      run(with(kNeedle, probe_procedure(kProbeCylinder, kProbeSupport, "{rotate: 5, steps: 2}")));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"report.json", "probe.csv", "probe/simulation.pvd", "probe/steps/step_0002.vtu"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
}

TEST_F(BadScenario, NeedleFreeScenarioWithoutLoad) {
  // Without its needle the base scenario only holds the model: a static load case in which nothing moves.
  std::string yaml = kBase;
  yaml.erase(yaml.find("needle:"), yaml.find("targets:") - yaml.find("needle:"));
  expect_error(yaml, {"s.yaml:3:",
                      "boundary_conditions: a scenario without 'needle' or 'needles' is a static load case",
                      "pressure"});
}
TEST_F(BadScenario, NeoHookeanLoadStepThatCannotConverge) {
  // The face x_min pushed 20 mm through the 16 mm block (λ₁ < 0 is no deformation): the Newton solve
  // halves its last step until the limit and the run ends naming the key and the step, writing nothing.
  std::string yaml = kBase;
  yaml.erase(yaml.find("needle:"), yaml.find("targets:") - yaml.find("needle:"));
  yaml.replace(yaml.find("material: {"), 11, "material: {model: neo-hookean, ");
  yaml.replace(yaml.find("  - {type: fixed, region: {cylinder"), std::string::npos,
               "  - {type: displacement, region: {box_face: x_min}, value: [20, 0, 0]}\n");
  expect_error(yaml, {"s.yaml:1:", "material.model = 'neo-hookean'", "the load step from load factor",
                      "did not converge after 10 halvings"});
}
// A flexible needle on neo-Hookean tissue: one line naming material.model's line and needle.flexible.
TEST_F(BadScenario, NeoHookeanWithAFlexibleNeedle) {
  std::string yaml = with("poisson_ratio: 0.45", "poisson_ratio: 0.45, model: neo-hookean");
  yaml.replace(yaml.find("  diameter: 1\n"), 14,
               "  diameter: 1\n  flexible: {youngs_modulus: 2.0e8, inner_diameter: 0.6}\n");
  expect_error(yaml, {"s.yaml:1:", "material.model = 'neo-hookean' with a flexible needle (needle.flexible",
                      "material.model: linear"});
}

TEST_F(BadScenario, NegativeModulusImageWithoutClamp) {
  const std::string img = (dir_ / "negative.mha").string();
  write_block(img, 10.0f, -4.0f);
  expect_error(kBase, {"material.youngs_modulus: image has 1 voxels", "-4", "material.clamp"}, img);
  // With a clamp the same image is accepted.
  const CliRun r = run(with("poisson_ratio: 0.45}", "poisson_ratio: 0.45, clamp: [1, 100]}"), img);
  EXPECT_EQ(r.code, 0) << r.err;
}
TEST_F(BadScenario, NaNModulusImage) {
  const std::string img = (dir_ / "nan.mha").string();
  write_block(img, 10.0f, std::nanf(""));
  expect_error(kBase, {"nan.mha"}, img);  // refused when the image is read (image_io), with or without clamp
}
TEST_F(BadScenario, MissingScenarioFile) {
  const fs::path out = dir_ / "out";
  const std::string cmd = std::string(VIM_PIPELINE_EXE) + " " + image_ + " --simulate " +
                          (dir_ / "nope.yaml").string() + " --out " + out.string() +
                          " 2> /dev/null > /dev/null";
  const int s = std::system(cmd.c_str());
  EXPECT_EQ(WIFEXITED(s) ? WEXITSTATUS(s) : -1, 1);
  EXPECT_TRUE(out_is_empty());
}
TEST_F(BadScenario, DuplicateKey) {
  expect_error(std::string(kBase) + "material: {youngs_modulus: 99}\n",
               {"s.yaml:15:", "duplicate key 'material' (first given on line 1)"});
  expect_error(with("  depth: 8\n", "  depth: 8\n  depth: 5\n"),
               {"s.yaml:9:", "duplicate key 'needle.depth' (first given on line 8)"});
}
// The voxel reference model is trilinear (Q1) whatever --degree says: a degree-2 request is warned about
// (stderr and report.json), and the model's degree in the report is 1.
TEST_F(BadScenario, VoxelModelWarnsThatDegreeTwoDoesNotApply) {
  const fs::path scen = dir_ / "s.yaml", out = dir_ / "out", err = dir_ / "err.txt";
  std::ofstream(scen) << kBase;
  const std::string cmd = std::string(VIM_PIPELINE_EXE) + " " + image_ + " --simulate " + scen.string() +
                          " --mesher voxel --degree 2 --export none --out " + out.string() + " 2> " +
                          err.string() + " > /dev/null";
  const int s = std::system(cmd.c_str());
  ASSERT_EQ(WIFEXITED(s) ? WEXITSTATUS(s) : -1, 0);
  std::ifstream in(out / "report.json");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string report = ss.str();
  EXPECT_NE(report.find("trilinear hexahedra (Q1) whatever the degree"), std::string::npos);
  std::ifstream e(err);
  std::stringstream es;
  es << e.rdbuf();
  EXPECT_NE(es.str().find("--degree 2 applies to the simplex meshes"), std::string::npos) << es.str();
}

// needle.tissues and --fit-forces.
namespace {
const char* kStickSlip = "  friction: {model: stick-slip, max_shear_per_length: 0.5}\n  cutting_force: 1\n";
}  // namespace

TEST_F(BadScenario, TissueEntryWithoutARegion) {
  expect_error(
      with("  friction: {model: stick}\n", std::string(kStickSlip) + "  tissues: [{cutting_force: 2}]\n"),
      {"s.yaml:13:", "missing key 'needle.tissues[0].region'", "modulus"});
}
TEST_F(BadScenario, TissueEntryWithANegativeValue) {
  expect_error(with("  friction: {model: stick}\n",
                    std::string(kStickSlip) + "  tissues:\n    - {region: {sphere: {center: [0, 0, 1], "
                                              "radius: 2}}, max_shear_per_length: -1}\n"),
               {"s.yaml:14:", "needle.tissues[0].max_shear_per_length must be >= 0, got -1"});
}
TEST_F(BadScenario, TissueEntryWithAnUnknownKey) {
  expect_error(with("  friction: {model: stick}\n",
                    std::string(kStickSlip) +
                        "  tissues:\n    - {region: {modulus: {min: 1, max: 5}}, friction: 2}\n"),
               {"s.yaml:14:", "unknown key 'needle.tissues[0].friction'", "max_shear_per_length"});
}
TEST_F(BadScenario, MeasuredForcesWithoutTheForceColumn) {
  std::ofstream(dir_ / "m.csv") << "depth,load\n1,2\n2,3\n";
  expect_error(with("  friction: {model: stick}\n", kStickSlip), {"m.csv:1:", "'depth' and 'force'"}, "",
               " --fit-forces " + (dir_ / "m.csv").string());
}
TEST_F(BadScenario, MeasuredForcesWithDepthThatDoesNotIncrease) {
  std::ofstream(dir_ / "m.csv") << "depth,force\n1,2\n3,3\n2,4\n";
  expect_error(with("  friction: {model: stick}\n", kStickSlip), {"m.csv:4:", "column 'depth' must increase"},
               "", " --fit-forces " + (dir_ / "m.csv").string());
}
TEST_F(BadScenario, MeasuredForcesWithANonNumericCell) {
  std::ofstream(dir_ / "m.csv") << "depth,force\n1,2\n2,n/a\n";
  expect_error(with("  friction: {model: stick}\n", kStickSlip),
               {"m.csv:3:", "column 'force' must be a number", "n/a"}, "",
               " --fit-forces " + (dir_ / "m.csv").string());
}
TEST_F(BadScenario, FitWithNothingToFit) {
  std::ofstream(dir_ / "m.csv") << "depth,force\n1,2\n2,3\n3,4\n4,5\n";
  expect_error(with("  friction: {model: stick}\n", std::string(kStickSlip) + "  fit: false\n"),
               {"s.yaml:6:", "nothing to fit", "fit: true"}, "",
               " --fit-forces " + (dir_ / "m.csv").string());
}

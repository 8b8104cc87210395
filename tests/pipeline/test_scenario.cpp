// Scenario parsing and validation (scenario.hpp): every key of the scenario format is read with its
// value, and every malformed input gives a ScenarioError that names the key, the value and the YAML line.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vim/pipeline/scenario/mesh_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

using namespace vim;
using namespace vim::pipeline;

namespace {

const char* kFull = R"(units: {length: mm, modulus: kPa}
material:
  youngs_modulus: image
  scale: 2.5
  clamp: [1.0, 1000.0]
  poisson_ratio: 0.45
mesh: {nodes: 3000, lambda: 0.3, degree: 2, min_dihedral: 12.5}
boundary_conditions:
  - {type: fixed, region: {box_face: y_min}}
  - {type: fixed, region: {cylinder: {center: [0, -20, 0], axis: [0, 0, 2], radius: 10}}}
  - {type: displacement, region: {box_face: z_max}, value: [0, 0, -2.0]}
  - {type: pressure, region: {box_face: z_max}, value: 1.5}
  - {type: traction, region: {sphere: {center: [1, 2, 3], radius: 4}}, value: [0.1, 0, 0]}
  - {type: displacement, region: {box: {min: [-1, -1, -1], max: [1, 1, 1]}}, value: [0, 0, 0], components: [x, z]}
needle:
  entry: [0, 0, -30]
  direction: [0, 0, 3]
  depth: 45.0
  steps: 45
  diameter: 1.27
  model: kinematic
  friction: {model: stick-slip, max_shear_per_length: 0.5}
  sample_spacing: 2.0
targets:
  - {name: lesion, position: [5, 2, 10]}
  - {name: apex, position: [0, 0, -20]}
output: {every: 3, fields: [displacement, strain]}
solver: {type: amg, tolerance: 1.0e-8}
)";

// The message of the ScenarioError thrown by parsing `yaml` (fails the test if none is thrown).
std::string error_of(const std::string& yaml, int dim = 3) {
  try {
    parse_scenario_text(yaml, dim, "s.yaml");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << yaml;
  return "";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto k = s.find(from);
  EXPECT_NE(k, std::string::npos) << from;
  if (k != std::string::npos) s.replace(k, from.size(), to);
  return s;
}

// Every (value, expected message part): `base` with `placeholder` replaced by value must fail with it.
void expect_errors(const std::string& base, const std::string& placeholder,
                   const std::vector<std::pair<std::string, std::string>>& cases) {
  for (const auto& [value, expect] : cases) {
    const std::string msg = error_of(replace(base, placeholder, value));
    EXPECT_NE(msg.find(expect), std::string::npos) << value << ": " << msg;
  }
}

const char* kMinimal = R"(boundary_conditions:
  - {type: fixed, region: {box_face: z_max}}
needle: {entry: [0, 0, 0], direction: [0, 0, 1], depth: 10, steps: 5, diameter: 1, friction: {model: stick}}
)";

}  // namespace

TEST(Scenario, EveryKeyIsParsed) {
  const Scenario s = parse_scenario_text(kFull, 3, "full.yaml");
  EXPECT_EQ(s.length_unit, "mm");
  EXPECT_EQ(s.modulus_unit, "kPa");
  EXPECT_TRUE(s.modulus_from_image);
  EXPECT_DOUBLE_EQ(s.scale, 2.5);
  ASSERT_TRUE(s.clamp);
  EXPECT_DOUBLE_EQ(s.clamp->first, 1.0);
  EXPECT_DOUBLE_EQ(s.clamp->second, 1000.0);
  EXPECT_DOUBLE_EQ(s.poisson_ratio, 0.45);
  EXPECT_EQ(*s.nodes, 3000);
  EXPECT_DOUBLE_EQ(*s.lambda, 0.3);
  EXPECT_EQ(*s.degree, 2u);
  EXPECT_DOUBLE_EQ(*s.min_dihedral, 12.5);

  ASSERT_EQ(s.boundary_conditions.size(), 6u);
  const auto& b = s.boundary_conditions;
  EXPECT_EQ(b[0].type, BoundaryConditionSpec::Type::fixed);
  EXPECT_EQ(b[0].region.kind, RegionSpec::Kind::box_face);
  EXPECT_EQ(b[0].region.axis, 1);
  EXPECT_FALSE(b[0].region.upper);
  EXPECT_EQ(b[0].line, 9);
  EXPECT_EQ(b[1].region.kind, RegionSpec::Kind::cylinder);
  EXPECT_DOUBLE_EQ(b[1].region.center[1], -20.0);
  EXPECT_DOUBLE_EQ(b[1].region.axis_vector[2], 1.0);  // normalised
  EXPECT_DOUBLE_EQ(b[1].region.radius, 10.0);
  EXPECT_EQ(b[2].type, BoundaryConditionSpec::Type::displacement);
  EXPECT_EQ(b[2].region.axis, 2);
  EXPECT_TRUE(b[2].region.upper);
  EXPECT_DOUBLE_EQ(b[2].value[2], -2.0);
  EXPECT_EQ(b[3].type, BoundaryConditionSpec::Type::pressure);
  EXPECT_DOUBLE_EQ(b[3].value[0], 1.5);
  EXPECT_EQ(b[4].type, BoundaryConditionSpec::Type::traction);
  EXPECT_EQ(b[4].region.kind, RegionSpec::Kind::sphere);
  EXPECT_DOUBLE_EQ(b[4].region.radius, 4.0);
  EXPECT_DOUBLE_EQ(b[4].value[0], 0.1);
  EXPECT_EQ(b[5].region.kind, RegionSpec::Kind::box);
  EXPECT_DOUBLE_EQ(b[5].region.lo[0], -1.0);
  EXPECT_DOUBLE_EQ(b[5].region.hi[2], 1.0);
  EXPECT_EQ(b[5].components, (std::vector<bool>{true, false, true}));

  ASSERT_EQ(s.needles.size(), 1u);
  EXPECT_FALSE(s.needle_list);
  const auto& n = s.needles[0];
  EXPECT_DOUBLE_EQ(n.entry[2], -30.0);
  EXPECT_DOUBLE_EQ(n.direction[2], 1.0);  // normalised
  EXPECT_DOUBLE_EQ(n.depth, 45.0);
  EXPECT_EQ(n.steps, 45);
  EXPECT_DOUBLE_EQ(n.diameter, 1.27);
  EXPECT_EQ(n.model, NeedleSpec::Model::kinematic);
  EXPECT_EQ(n.friction, NeedleSpec::Friction::stick_slip);
  EXPECT_DOUBLE_EQ(n.max_shear_per_length, 0.5);
  EXPECT_DOUBLE_EQ(n.sample_spacing, 2.0);

  ASSERT_EQ(s.targets.size(), 2u);
  EXPECT_EQ(s.targets[0].name, "lesion");
  EXPECT_DOUBLE_EQ(s.targets[0].position[1], 2.0);
  EXPECT_EQ(s.targets[1].name, "apex");
  EXPECT_EQ(s.output_every, 3);
  EXPECT_EQ(s.output_fields, (std::vector<std::string>{"displacement", "strain"}));
  EXPECT_TRUE(s.wants("strain"));
  EXPECT_FALSE(s.wants("stress"));
  EXPECT_EQ(s.solver_type, "amg");
  EXPECT_DOUBLE_EQ(s.solver_tolerance, 1e-8);
  EXPECT_EQ(s.text, kFull);
}

// The scenario's mesh keys reach the mesher's options; keys it does not give keep the base's values.
TEST(Scenario, MeshKeysBecomeVimOptions) {
  vim::pipeline::MeshOptions base;
  base.lambda = 0.7;
  base.min_dihedral_deg = 3.0;
  base.max_iterations = 17;
  const vim::VimOptions full =
      vim::pipeline::with_scenario_mesh(base, parse_scenario_text(kFull, 3, "full.yaml")).vim_options();
  EXPECT_DOUBLE_EQ(full.lambda, 0.3);
  EXPECT_DOUBLE_EQ(full.min_dihedral_deg, 12.5);
  EXPECT_EQ(full.max_iterations, 17);
  const vim::VimOptions minimal =
      vim::pipeline::with_scenario_mesh(base, parse_scenario_text(kMinimal, 3, "m.yaml")).vim_options();
  EXPECT_DOUBLE_EQ(minimal.lambda, 0.7);
  EXPECT_DOUBLE_EQ(minimal.min_dihedral_deg, 3.0);
  const vim::VimOptions defaults =
      vim::pipeline::with_scenario_mesh({}, parse_scenario_text(kMinimal, 3, "m.yaml")).vim_options();
  EXPECT_DOUBLE_EQ(defaults.lambda, vim::VimOptions{}.lambda);  // what the CLI runs without --lambda
}

TEST(Scenario, DefaultsAndNumberModulus) {
  const Scenario s = parse_scenario_text(std::string(kMinimal) + "material: {youngs_modulus: 12.5}\n", 3);
  EXPECT_FALSE(s.modulus_from_image);
  EXPECT_DOUBLE_EQ(s.youngs_modulus, 12.5);
  EXPECT_DOUBLE_EQ(s.poisson_ratio, 0.49);
  EXPECT_FALSE(s.nodes);
  EXPECT_EQ(s.output_every, 1);
  EXPECT_EQ(s.solver_type, "auto");
  EXPECT_EQ(s.needles[0].model, NeedleSpec::Model::kinematic);
  EXPECT_EQ(s.needles[0].friction, NeedleSpec::Friction::stick);  // as kMinimal says
  const auto e = scenario_modulus(s, {1.0, 2.0});
  EXPECT_EQ(e, (std::vector<double>{12.5, 12.5}));
}

// Stick-slip is the default friction: without a model the friction is stick-slip, and its limit has no
// default, so a needle without friction (or with stick-slip and no limit) is an error naming the key;
// {model: stick} is the no-slip limit.
TEST(Scenario, StickSlipIsTheDefaultFrictionAndItsLimitIsRequired) {
  const std::string plain = replace(kMinimal, ", friction: {model: stick}}", "}");
  const std::string missing = error_of(plain);
  EXPECT_NE(missing.find("s.yaml:3: missing key 'needle.friction.max_shear_per_length'"), std::string::npos)
      << missing;
  EXPECT_NE(missing.find("stick-slip is the default"), std::string::npos) << missing;
  EXPECT_NE(missing.find("{model: stick}"), std::string::npos) << missing;
  const std::string no_limit = error_of(replace(kMinimal, "{model: stick}", "{model: stick-slip}"));
  EXPECT_NE(no_limit.find("missing key 'needle.friction.max_shear_per_length'"), std::string::npos)
      << no_limit;
  const Scenario limit_only =
      parse_scenario_text(replace(kMinimal, "{model: stick}", "{max_shear_per_length: 12}"), 3);
  EXPECT_EQ(limit_only.needles[0].friction, NeedleSpec::Friction::stick_slip);
  EXPECT_DOUBLE_EQ(limit_only.needles[0].max_shear_per_length, 12.0);
  // The force model takes friction_per_length and needs no friction key.
  EXPECT_NO_THROW(
      parse_scenario_text(replace(plain, "diameter: 1}", "diameter: 1, model: force, tip_force: 2}"), 3));
}

// A scenario without a needle is a static load case: it parses when a condition loads the model (a
// non-zero displacement, pressure or traction) and is refused, naming the file, line and key, when
// nothing would move or when it asks for a needle refinement.
TEST(Scenario, NeedleFreeScenariosAreStaticLoadCases) {
  const std::string held = "boundary_conditions:\n  - {type: fixed, region: {box_face: z_min}}\n";
  for (const char* load : {"  - {type: displacement, region: {box_face: z_max}, value: [0, 0, -1]}\n",
                           "  - {type: pressure, region: {box_face: z_max}, value: 2}\n",
                           "  - {type: traction, region: {box_face: z_max}, value: [0, 1, 0]}\n"}) {
    const Scenario s = parse_scenario_text(held + load, 3, "s.yaml");
    EXPECT_TRUE(s.needles.empty()) << load;
  }
  for (const char* none :
       {"", "  - {type: displacement, region: {box_face: z_max}, value: [0, 0, 0]}\n",
        "  - {type: pressure, region: {box_face: z_max}, value: 0}\n",
        "  - {type: displacement, region: {box_face: z_max}, value: [0, 0, -1], components: [x]}\n"}) {
    const std::string m = error_of(held + none);
    EXPECT_NE(
        m.find(
            "s.yaml:2: boundary_conditions: a scenario without 'needle' or 'needles' is a static load case"),
        std::string::npos)
        << none << ": " << m;
  }
  const std::string refined = error_of(held + "  - {type: pressure, region: {box_face: z_max}, value: 2}\n" +
                                       "mesh: {needle_refinement: {size_ratio: 0.5, radius: 2}}\n");
  EXPECT_NE(refined.find("s.yaml:4: mesh.needle_refinement"), std::string::npos) << refined;
}

TEST(Scenario, NeedlesList) {
  const std::string y = R"(boundary_conditions: [{type: fixed, region: {box_face: x_min}}]
needles:
  - {name: a, entry: [0, 0], direction: [1, 0], depth: 5, steps: 2, diameter: 1, friction: {model: stick}}
  - {entry: [0, 1], direction: [1, 1], depth: 5, steps: 2, diameter: 1, model: force, tip_force: 3}
)";
  const Scenario s = parse_scenario_text(y, 2);
  ASSERT_EQ(s.needles.size(), 2u);
  EXPECT_TRUE(s.needle_list);
  EXPECT_EQ(s.needles[0].name, "a");
  EXPECT_EQ(s.needles[1].name, "needle_2");
  EXPECT_NEAR(s.needles[1].direction[0], std::sqrt(0.5), 1e-15);
  EXPECT_EQ(s.needles[1].model, NeedleSpec::Model::force);
  EXPECT_DOUBLE_EQ(s.needles[1].tip_force, 3.0);
}

TEST(Scenario, ModulusFromImageScaleAndClamp) {
  Scenario s = parse_scenario_text(std::string(kMinimal) + "material: {scale: 2, clamp: [3, 10]}\n", 3);
  EXPECT_EQ(scenario_modulus(s, {1.0, 2.0, 4.0, 100.0, -5.0}),
            (std::vector<double>{3.0, 4.0, 8.0, 10.0, 3.0}));
  s.clamp.reset();
  EXPECT_THROW(scenario_modulus(s, {1.0, -1.0}), ScenarioError);
  EXPECT_THROW(scenario_modulus(s, {std::nan("")}), ScenarioError);
}

struct BadCase {
  const char* from;
  const char* to;
  std::vector<const char*> expect;  // substrings of the message
};

TEST(Scenario, BadInputsNameKeyValueAndLine) {
  const std::vector<BadCase> cases = {
      {"units:", "unit:", {"unknown key 'unit'", "valid keys", "boundary_conditions", "s.yaml:1:"}},
      {"scale: 2.5", "scael: 2.5", {"unknown key 'material.scael'", "poisson_ratio", "s.yaml:4:"}},
      {"poisson_ratio: 0.45", "poisson_ratio: 0.5", {"material.poisson_ratio", "0.5", "< 0.5", "s.yaml:6:"}},
      {"poisson_ratio: 0.45", "poisson_ratio: -1.5", {"material.poisson_ratio", "(-1, 0.5)"}},
      {"poisson_ratio: 0.45", "poisson_ratio: soft", {"material.poisson_ratio must be a number", "'soft'"}},
      {"youngs_modulus: image",
       "youngs_modulus: picture",
       {"material.youngs_modulus", "'image' or a number", "'picture'"}},
      {"youngs_modulus: image", "youngs_modulus: -3", {"material.youngs_modulus", "-3"}},
      {"clamp: [1.0, 1000.0]", "clamp: [10, 1]", {"material.clamp", "min <= max"}},
      {"clamp: [1.0, 1000.0]", "clamp: 5", {"material.clamp must be a list"}},
      {"degree: 2", "degree: 3", {"mesh.degree must be 1 or 2", "3"}},
      {"nodes: 3000", "nodes: 1.5", {"mesh.nodes must be an integer", "'1.5'"}},
      {"lambda: 0.3", "lambda: 1.0", {"mesh.lambda", "[0, 1)"}},
      {"min_dihedral: 12.5", "min_dihedral: 60", {"mesh.min_dihedral must be in [0, 60) degrees", "60"}},
      {"box_face: y_min",
       "box_face: y_low",
       {"box_face = 'y_low'", "x_min, x_max, y_min, y_max, z_min, z_max", "s.yaml:9:"}},
      {"{type: fixed, region: {box_face: y_min}}",
       "{type: clamped, region: {box_face: y_min}}",
       {"boundary_conditions[0].type = 'clamped'", "fixed, displacement, pressure, traction"}},
      {"radius: 10}", "radius: 0}", {"boundary_conditions[1].region.cylinder.radius must be > 0", "0"}},
      {"radius: 10}",
       "radius: 10, length: -40}",
       {"boundary_conditions[1].region.cylinder.length must be > 0", "-40", "s.yaml:10:"}},
      {"radius: 10}",
       "radius: 10, length: long}",
       {"boundary_conditions[1].region.cylinder.length must be a number", "'long'"}},
      {"axis: [0, 0, 2]",
       "axis: [0, 0, 0]",
       {"boundary_conditions[1].region.cylinder.axis must be a non-zero vector"}},
      {"value: [0, 0, -2.0]",
       "value: [0, -2.0]",
       {"boundary_conditions[2].value must be a list of 3 numbers", "list of 2"}},
      {", value: 1.5}", "}", {"missing key 'boundary_conditions[3].value'"}},
      {"components: [x, z]", "components: [x, w]", {"components[1] = 'w'", "x, y, z"}},
      {"entry: [0, 0, -30]", "entry: [0, 0]", {"needle.entry must be a list of 3 numbers"}},
      {"entry: [0, 0, -30]", "entry: [0, zero, -30]", {"needle.entry[1] must be a number", "'zero'"}},
      {"direction: [0, 0, 3]",
       "direction: [0, 0, 0]",
       {"needle.direction must be a non-zero vector", "s.yaml:17:"}},
      {"depth: 45.0", "depth: -45", {"needle.depth must be > 0", "-45", "s.yaml:18:"}},
      {"depth: 45.0", "depth: 0", {"needle.depth must be > 0"}},
      {"steps: 45", "steps: 0", {"needle.steps must be > 0", "0"}},
      {"steps: 45", "steps: 4.5", {"needle.steps must be an integer", "'4.5'"}},
      {"diameter: 1.27", "diameter: -1", {"needle.diameter must be > 0", "-1"}},
      {"diameter: 1.27", "diameter: [1]", {"needle.diameter must be a number", "a list"}},
      {"  diameter: 1.27\n", "", {"missing key 'needle.diameter'"}},
      {"model: kinematic", "model: spring", {"needle.model = 'spring'", "kinematic, force"}},
      {"model: stick-slip", "model: glue", {"needle.friction.model = 'glue'", "stick, stick-slip"}},
      {"max_shear_per_length: 0.5",
       "max_shear: 0.5",
       {"unknown key 'needle.friction.max_shear'", "max_shear_per_length"}},
      {"every: 3", "every: -1", {"output.every must be >= 0"}},
      {"fields: [displacement, strain]",
       "fields: [displacement, pressure]",
       {"output.fields[1] = 'pressure'", "von_mises"}},
      {"type: amg", "type: gauss", {"solver.type = 'gauss'", "auto, direct, amg, multigrid"}},
      {"tolerance: 1.0e-8", "tolerance: 0", {"solver.tolerance must be > 0"}},
      {"{name: apex,", "{name: lesion,", {"targets[1].name = 'lesion' is used twice"}},
      {"{name: apex,", "{name: 2apex,", {"targets[1].name = '2apex' must be an identifier"}},
      {"position: [5, 2, 10]",
       "position: [5, 2, 10, 1]",
       {"targets[0].position must be a list of 3 numbers"}},
      {"needle:", "needel:", {"unknown key 'needel'"}},
      {"mesh: {nodes: 3000, lambda: 0.3, degree: 2, min_dihedral: 12.5}",
       "mesh: [3000]",
       {"mesh must be a mapping, got a list", "s.yaml:7:"}},
  };
  for (const auto& c : cases) {
    const std::string msg = error_of(replace(kFull, c.from, c.to));
    for (const char* e : c.expect)
      EXPECT_NE(msg.find(e), std::string::npos)
          << "case '" << c.to << "': message: " << msg << "\n  lacks: " << e;
  }
}

TEST(Scenario, MissingTopLevelKeysAndSyntax) {
  // No needle and nothing that loads the model: a static load case in which nothing would move.
  const std::string no_load = error_of("boundary_conditions: [{type: fixed, region: {box_face: x_min}}]\n");
  EXPECT_NE(
      no_load.find(
          "s.yaml:1: boundary_conditions: a scenario without 'needle' or 'needles' is a static load case"),
      std::string::npos)
      << no_load;
  EXPECT_NE(error_of("needle: {entry: [0,0,0], direction: [0,0,1], depth: 1, steps: 1, diameter: 1, "
                     "friction: {model: stick}}\n")
                .find("missing key 'boundary_conditions'"),
            std::string::npos);
  EXPECT_NE(error_of("").find("empty"), std::string::npos);
  EXPECT_NE(error_of("needle: [1, 2\n").find("YAML syntax error"), std::string::npos);
  const std::string both = std::string(kMinimal) + "needles: []\n";
  EXPECT_NE(error_of(both).find("either 'needle' or 'needles'"), std::string::npos);
  // 2D: only x/y faces and 2-vectors.
  const std::string y2 = R"(boundary_conditions: [{type: fixed, region: {box_face: z_min}}]
needle: {entry: [0, 0], direction: [0, 1], depth: 1, steps: 1, diameter: 1, friction: {model: stick}}
)";
  EXPECT_NE(
      error_of(y2, 2).find(
          "box_face = 'z_min' is not a face of the 2D image box; use one of: x_min, x_max, y_min, y_max"),
      std::string::npos);
  const std::string y3 = R"(boundary_conditions: [{type: fixed, region: {box_face: y_max}}]
needle: {entry: [0, 0, 0], direction: [0, 1], depth: 1, steps: 1, diameter: 1, friction: {model: stick}}
)";
  EXPECT_NE(error_of(y3, 2).find(
                "needle.entry must be a list of 2 numbers ([x, y]) for a 2D image, got a list of 3"),
            std::string::npos);
  EXPECT_THROW(read_scenario("/nonexistent/dir/s.yaml", 3), ScenarioError);
  // Only loads, no fixed or displacement condition: singular.
  const std::string loads = R"(boundary_conditions:
  - {type: pressure, region: {box_face: z_max}, value: 1.5}
needle: {entry: [0, 0, 0], direction: [0, 0, 1], depth: 10, steps: 5, diameter: 1, friction: {model: stick}}
)";
  const std::string m = error_of(loads);
  EXPECT_NE(m.find("boundary_conditions has no 'fixed' or 'displacement' condition"), std::string::npos) << m;
  EXPECT_NE(m.find("singular"), std::string::npos) << m;
}

TEST(Scenario, GeometryAgainstTheImageBox) {
  using V = Eigen::Vector3d;
  const V lo(-10, -10, 0), hi(10, 10, 40);
  WorldTransform<3> id;
  auto scen = [](const std::string& needle, const std::string& target) {
    return parse_scenario_text("boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\nneedle: " +
                                   needle + "\ntargets: [{name: t, position: " + target + "}]\n",
                               3, "g.yaml");
  };
  const std::string ok =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 40, steps: 4, diameter: 1, friction: {model: stick}}";
  EXPECT_NO_THROW(check_scenario_geometry<3>(scen(ok, "[0, 0, 39]"), lo, hi,
                                             id));  // entry on the surface, tip at the far face
  auto msg = [&](const std::string& needle, const std::string& target, const WorldTransform<3>& t) {
    try {
      check_scenario_geometry<3>(scen(needle, target), lo, hi, t);
    } catch (const ScenarioError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(
      msg("{entry: [0, 0, -1], direction: [0, 0, 1], depth: 5, steps: 4, diameter: 1, friction: {model: "
          "stick}}",
          "[0, 0, 1]", id)
          .find("needle.entry [0, 0, -1] is outside the image box (world [-10, -10, 0] .. [10, 10, 40])"),
      std::string::npos);
  EXPECT_NE(msg("{entry: [0, 0, 0], direction: [0, 0, 1], depth: 41, steps: 4, diameter: 1, friction: "
                "{model: stick}}",
                "[0, 0, 1]", id)
                .find("needle.depth = 41 takes the tip out of the image box"),
            std::string::npos);
  EXPECT_NE(msg("{entry: [0, 0, 0], direction: [0, 0, -1], depth: 1, steps: 4, diameter: 1, friction: "
                "{model: stick}}",
                "[0, 0, 1]", id)
                .find("points out of the image box"),
            std::string::npos);
  EXPECT_NE(msg(ok, "[0, 11, 5]", id).find("target 't' position [0, 11, 5] is outside the image box"),
            std::string::npos);
  // The diameter must fit in the box across the needle. Truth: the box's width perpendicular to the needle,
  // found here by brute force as the smallest of sum_d |p_d| extent_d over 36,000 unit vectors p
  // perpendicular to the needle: 20 along z, 20 along x (the y extent), and 20·√2 = 28.28 along the
  // xy-diagonal (the widths along z are 40).
  auto brute_width = [&](const V& axis) {
    const V u = axis.unitOrthogonal(), w = axis.cross(u);
    double best = 1e300;
    for (int k = 0; k < 36000; ++k) {
      const double t = 2.0 * M_PI * k / 36000.0;
      best = std::min(best, (std::cos(t) * u + std::sin(t) * w).cwiseAbs().dot(hi - lo));
    }
    return best;
  };
  const std::string along_z =
      "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 5, steps: 1, diameter: D, friction: {model: stick}}";
  const std::string diagonal =
      "{entry: [-5, -5, 20], direction: [1, 1, 0], depth: 5, steps: 1, diameter: D, friction: {model: "
      "stick}}";
  for (const auto& [needle, axis] :
       {std::pair{along_z, V(0, 0, 1)}, std::pair{diagonal, V(1, 1, 0).normalized()}}) {
    const double width = brute_width(axis);
    EXPECT_EQ(msg(replace(needle, "D", std::to_string(0.999 * width)), "[0, 0, 1]", id), "no error")
        << needle;
    const std::string big = msg(replace(needle, "D", std::to_string(1.001 * width)), "[0, 0, 1]", id);
    EXPECT_NE(big.find("g.yaml:2: needle.diameter = "), std::string::npos) << big;
    EXPECT_NE(big.find("is larger than the image box"), std::string::npos) << big;
  }
  // A rotated image: world = origin + D (p - origin); frame box [-10,10]x[-10,10]x[0,40] about origin 0, D =
  // Rz(90°).
  WorldTransform<3> rot;
  rot.direction << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_EQ(msg("{entry: [-10, 5, 20], direction: [1, 0, 0], depth: 20, steps: 2, diameter: 1, friction: "
                "{model: stick}}",
                "[5, 0, 1]", rot),
            "no error");
  EXPECT_NE(msg("{entry: [-10, 5, 20], direction: [1, 0, 0], depth: 21, steps: 2, diameter: 1, friction: "
                "{model: stick}}",
                "[5, 0, 1]", rot)
                .find("largest depth"),
            std::string::npos);
  // An oblique image (Rz(45°)): the world point (13, 3, 5) lies inside the bounding box of the box's
  // corners (|x|, |y| <= 14.14) but outside the image; the message says where it is along the image's
  // axes: D^T (13, 3, 5) = (11.3137, -7.07107, 5), beyond the box's 10.
  WorldTransform<3> obl;
  const double c = std::sqrt(0.5);
  obl.direction << c, -c, 0, c, c, 0, 0, 0, 1;
  const std::string m = msg(ok, "[13, 3, 5]", obl);
  EXPECT_NE(m.find("target 't' position [13, 3, 5] is outside the image box (an oblique box: the world "
                   "bounding box of its corners is "
                   "[-14.1421, -14.1421, 0] .. [14.1421, 14.1421, 40], its centre [0, 0, 20])"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("along the image axes from voxel 0's centre it is at [11.3137, -7.07107, 5], the box "
                   "spans [-10, -10, 0] .. [10, 10, 40]"),
            std::string::npos)
      << m;
  EXPECT_EQ(msg(ok, "[0, 0, 1]", id).find("along the image axes"),
            std::string::npos);                      // axis-aligned: no frame part
  EXPECT_EQ(msg(ok, "[9, 3, 5]", obl), "no error");  // D^T (9, 3, 5) = (8.49, -4.24, 5): inside
}

// Components are world axes. On an image whose axes are world axes (a signed permutation) they map to
// image axes; on an oblique one the simulation holds them along the world axes (DirichletBC::axes,
// tests/pipeline/test_simulation.cpp), so the geometry check accepts them on any image.
TEST(Scenario, ComponentsAreAcceptedOnAnyImageAndMapToImageAxesWhenAligned) {
  using V = Eigen::Vector3d;
  const V lo(-10, -10, 0), hi(10, 10, 40);
  const Scenario with = parse_scenario_text(
      "boundary_conditions:\n  - {type: fixed, region: {box_face: z_max}}\n"
      "  - {type: fixed, region: {box_face: z_min}, components: [z]}\n"
      "needle: {entry: [0, 0, 1], direction: [0, 0, 1], depth: 5, steps: 2, diameter: 1, friction: {model: "
      "stick}}\n",
      3, "c.yaml");
  WorldTransform<3> id, perm, obl;
  perm.direction << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // Rz(90°): image axes are world axes
  const double c = std::sqrt(0.5);
  obl.direction << c, -c, 0, c, c, 0, 0, 0, 1;  // Rz(45°)
  for (const auto* t : {&id, &perm, &obl}) EXPECT_NO_THROW(check_scenario_geometry<3>(with, lo, hi, *t));
  EXPECT_TRUE(id.axis_aligned());
  EXPECT_TRUE(perm.axis_aligned());
  EXPECT_FALSE(obl.axis_aligned());
  EXPECT_EQ(perm.world_axis_of(0), 1);
  EXPECT_EQ(perm.world_axis_of(1), 0);
  EXPECT_EQ(obl.world_axis_of(0), -1);
  EXPECT_EQ(obl.world_axis_of(2), 2);
}

TEST(Scenario, ModulusImageNeedsClampForNegativeOrNaN) {
  Image<3> img({{4, 4, 4}}, {{1, 1, 1}}, {{0, 0, 0}}, 10.0f);
  const Scenario plain = parse_scenario_text(kMinimal, 3);
  EXPECT_NO_THROW(check_modulus_image(plain, img));
  img.data[5] = -2.0f;
  try {
    check_modulus_image(plain, img);
    ADD_FAILURE() << "negative voxel accepted";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("material.youngs_modulus: image has 1 voxels"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("material.clamp"), std::string::npos);
  }
  img.data[5] = std::nanf("");
  EXPECT_THROW(check_modulus_image(plain, img), ScenarioError);
  const Scenario clamped = parse_scenario_text(std::string(kMinimal) + "material: {clamp: [1, 100]}\n", 3);
  EXPECT_NO_THROW(check_modulus_image(clamped, img));
  const Scenario constant = parse_scenario_text(std::string(kMinimal) + "material: {youngs_modulus: 5}\n", 3);
  EXPECT_NO_THROW(check_modulus_image(constant, img));
}

TEST(Scenario, ElasticRegionSupportAndCuttingDistance) {
  const std::string base = R"(boundary_conditions:
  - {type: fixed, region: {box_face: z_max}}
  - {type: fixed, region: {cylinder: {center: [0, -20, 0], axis: [0, 0, 1], radius: 6}}, support: SUPPORT}
needle: {entry: [0, 0, 0], direction: [0, 0, 1], depth: 10, steps: 5, diameter: 1, friction: {model: stick}, cutting_distance: 0.5}
)";
  const Scenario s =
      parse_scenario_text(replace(base, "SUPPORT", "{elastic: {stiffness: 15, spacing: 0.5}}"), 3);
  EXPECT_EQ(s.boundary_conditions[0].support, BoundaryConditionSpec::Support::nodes);  // the default
  EXPECT_EQ(s.boundary_conditions[1].support, BoundaryConditionSpec::Support::elastic);
  EXPECT_DOUBLE_EQ(s.boundary_conditions[1].support_stiffness, 15.0);
  EXPECT_DOUBLE_EQ(s.boundary_conditions[1].support_spacing, 0.5);
  EXPECT_DOUBLE_EQ(s.needles[0].cutting_distance, 0.5);
  const Scenario n = parse_scenario_text(replace(base, "SUPPORT", "nodes"), 3);
  EXPECT_EQ(n.boundary_conditions[1].support, BoundaryConditionSpec::Support::nodes);
  EXPECT_DOUBLE_EQ(parse_scenario_text(kMinimal, 3).needles[0].cutting_distance, 0.0);  // default
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"elastic", "elastic needs a stiffness"},
      {"{elastic: {stiffness: 0}}", "support.elastic.stiffness must be > 0"},
      {"{elastic: {stiffness: 1, spacing: -1}}", "support.elastic.spacing must be > 0"},
      {"{elastic: {stifness: 1}}", "unknown key 'boundary_conditions[1].support.elastic.stifness'"},
      {"{elastic: {spacing: 1}}", "missing key 'boundary_conditions[1].support.elastic.stiffness'"},
      {"glue", "support = 'glue' is not valid"},
  };
  expect_errors(base, "SUPPORT", bad);
  EXPECT_NE(error_of(replace(replace(base, "SUPPORT", "nodes"), "{box_face: z_max}}",
                             "{box_face: z_max}, support: nodes}"))
                .find("support applies only to type fixed on a volume region"),
            std::string::npos);
  const std::string plain = replace(base, "SUPPORT", "nodes");
  EXPECT_NE(error_of(replace(plain, "cutting_distance: 0.5", "cutting_distance: -1"))
                .find("needle.cutting_distance must be >= 0"),
            std::string::npos);
  EXPECT_NE(
      error_of(replace(plain, "cutting_distance: 0.5", "cutting_distance: 10")).find("less than the depth"),
      std::string::npos);
  // The force model loads the newest point with the tip force: a cutting distance would leave the first
  // millimetres without any force (a probe saw 0 N up to the first point, then 150), so it is refused.
  EXPECT_NE(error_of(replace(plain, "diameter: 1, friction: {model: stick},",
                             "diameter: 1, model: force, tip_force: 1,"))
                .find("needle.cutting_distance applies only to needle model 'kinematic'"),
            std::string::npos);
}

// mesh.needle_refinement: parsed, validated with messages naming the key; needle_paths gives each
// needle's segment in frame coordinates (rotated image: frame = direction^T (world − origin) + origin).
TEST(Scenario, NeedleRefinementAndPaths) {
  const std::string base = std::string(kMinimal) + "mesh: {nodes: 500, needle_refinement: REFINE}\n";
  const Scenario s = parse_scenario_text(replace(base, "REFINE", "{size_ratio: 0.5, radius: 6}"), 3);
  ASSERT_TRUE(s.needle_refinement.has_value());
  EXPECT_DOUBLE_EQ(s.needle_refinement->size_ratio, 0.5);
  EXPECT_DOUBLE_EQ(s.needle_refinement->radius, 6.0);
  EXPECT_FALSE(parse_scenario_text(kMinimal, 3).needle_refinement.has_value());
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{size_ratio: 0, radius: 6}", "mesh.needle_refinement.size_ratio must be in (0, 1]"},
      {"{size_ratio: 1.5, radius: 6}", "got 1.5"},
      {"{size_ratio: 0.5, radius: -2}", "mesh.needle_refinement.radius must be > 0"},
      {"{size_ratio: 0.5}", "missing key 'mesh.needle_refinement.radius'"},
      {"{size_ratio: 0.5, radius: 6, width: 2}", "unknown key 'mesh.needle_refinement.width'"},
      {"0.5", "mesh.needle_refinement must be a mapping"},
  };
  expect_errors(base, "REFINE", bad);

  // A frame rotated by 90° about z around origin o: world = o + R (frame − o).
  WorldTransform<3> tf;
  tf.origin = Eigen::Vector3d(1, 2, 3);
  tf.direction << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  Scenario two = parse_scenario_text(R"(boundary_conditions:
  - {type: fixed, region: {box_face: z_max}}
needles:
  - {entry: [1, 2, 3], direction: [0, 2, 0], depth: 10, steps: 5, diameter: 1, friction: {model: stick}}
  - {entry: [0, 0, 0], direction: [0, 0, 1], depth: 4, steps: 5, diameter: 1, friction: {model: stick}}
)",
                                     3);
  const auto paths = needle_paths<3>(two, tf);
  ASSERT_EQ(paths.size(), 2u);
  EXPECT_LT((paths[0].entry - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  EXPECT_LT((paths[0].axis - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);  // R^T (0, 1, 0)
  EXPECT_DOUBLE_EQ(paths[0].depth, 10.0);
  EXPECT_LT((tf.to_world(paths[1].entry) - Eigen::Vector3d(0, 0, 0)).norm(), 1e-12);
  // Distance to the segment: beside it, beyond the tip, behind the entry.
  EXPECT_NEAR(paths[0].distance(Eigen::Vector3d(5, 5, 3)), 3.0, 1e-12);
  EXPECT_NEAR(paths[0].distance(Eigen::Vector3d(14, 2, 7)), 5.0, 1e-12);
  EXPECT_NEAR(paths[0].distance(Eigen::Vector3d(-2, 6, 3)), 5.0, 1e-12);
}

// A repeated key is refused (yaml-cpp would keep both and look up the first, silently dropping the
// second), at the top level and inside a block, naming both lines.
TEST(Scenario, DuplicateKeysAreErrors) {
  const std::string top =
      error_of(std::string(kMinimal) + "material: {poisson_ratio: 0.3}\nmaterial: {poisson_ratio: 0.2}\n");
  EXPECT_NE(top.find("s.yaml:5:"), std::string::npos) << top;
  EXPECT_NE(top.find("duplicate key 'material' (first given on line 4)"), std::string::npos) << top;
  const std::string inner = error_of(replace(kMinimal, "depth: 10,", "depth: 10, depth: 5,"));
  EXPECT_NE(inner.find("duplicate key 'needle.depth'"), std::string::npos) << inner;
}

// Directions are normalised whatever their magnitude: a squared norm that overflows (1e200) or
// underflows (1e-170) must not turn the direction into zeros or into an error.
TEST(Scenario, DirectionsOfAnyMagnitudeAreNormalised) {
  for (const char* d : {"[1e200, 0, 1e200]", "[1e-170, 0, 1e-170]", "[3, 0, 3]"}) {
    const Scenario s =
        parse_scenario_text(replace(kMinimal, "direction: [0, 0, 1]", std::string("direction: ") + d), 3);
    ASSERT_EQ(s.needles.size(), 1u);
    EXPECT_NEAR(s.needles[0].direction[0], std::sqrt(0.5), 1e-15) << d;
    EXPECT_EQ(s.needles[0].direction[1], 0.0) << d;
    EXPECT_NEAR(s.needles[0].direction[2], std::sqrt(0.5), 1e-15) << d;
  }
}

// Keys that the chosen model would ignore are refused, as tip_force is with the kinematic model.
TEST(Scenario, KeysTheModelWouldIgnoreAreErrors) {
  const std::string friction =
      error_of(replace(kMinimal, "diameter: 1,", "diameter: 1, model: force, tip_force: 5,"));
  EXPECT_NE(friction.find("needle.friction applies only to needle model 'kinematic'"), std::string::npos)
      << friction;
  const std::string scale = error_of(std::string(kMinimal) + "material: {youngs_modulus: 20, scale: 3}\n");
  EXPECT_NE(scale.find("material.scale applies only to youngs_modulus: image"), std::string::npos) << scale;
  // scale 1 with a constant modulus changes nothing and is accepted.
  EXPECT_NO_THROW(
      parse_scenario_text(std::string(kMinimal) + "material: {youngs_modulus: 20, scale: 1}\n", 3));
  const std::string spacing =
      error_of(replace(kMinimal, "diameter: 1, friction: {model: stick}}",
                       "diameter: 1, friction: {model: stick}, sample_spacing: 1.0e-8}"));
  EXPECT_NE(spacing.find("more than 100000 shaft points"), std::string::npos) << spacing;
  const std::string clamp =
      error_of(std::string(kMinimal) + "material: {youngs_modulus: image, clamp: [1, 2, 3]}\n");
  EXPECT_NE(clamp.find("got a list of 3"), std::string::npos) << clamp;
}

TEST(Scenario, RegionTypesAreTheParsersTableAndDocumented) {
  EXPECT_EQ(vim::pipeline::region_types(),
            (std::vector<std::string>{"box_face", "box", "sphere", "cylinder", "label"}));
  std::ifstream in(std::string(VIM_SOURCE_DIR) + "/docs/architecture.md");
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& name : vim::pipeline::region_types())
    EXPECT_NE(doc.find("`" + name + "`"), std::string::npos) << name;
}

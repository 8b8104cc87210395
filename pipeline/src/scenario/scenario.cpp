// Scenario YAML parsing and validation (scenario.hpp). yaml-cpp gives no position for missing keys or
// bad conversions, so every access goes through the small checkers below, which name the key path,
// the YAML line and the valid values.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <vim/needle/friction_law.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

namespace {

// A region type of the scenario: its key (`region: {KEY: …}`) and how its value is read.
struct RegionType {
  const char* name;
  RegionSpec::Kind kind;
  void (*read)(const Reader& r, const YAML::Node& v, const std::string& p, int dim, RegionSpec& reg);
};

void read_box_face(const Reader& r, const YAML::Node& v, const std::string& p, int dim, RegionSpec& reg) {
  std::vector<std::string> valid(kFaceNames, kFaceNames + 2 * dim);
  reg.face = r.string(v, p);
  const auto it = std::find(valid.begin(), valid.end(), reg.face);
  if (it == valid.end())
    r.fail(v, p + " = '" + reg.face + "' is not a face of the " + std::to_string(dim) +
                  "D image box; use one of: " + join(valid));
  const int k = static_cast<int>(it - valid.begin());
  reg.axis = k / 2;
  reg.upper = (k % 2) == 1;
}

void read_box(const Reader& r, const YAML::Node& v, const std::string& p, int dim, RegionSpec& reg) {
  const Fields f = r.check_keys(v, p, {"min", "max"});
  reg.lo = r.vector(r.require(f, "min", p + ".min"), p + ".min", dim);
  reg.hi = r.vector(r.require(f, "max", p + ".max"), p + ".max", dim);
  for (int d = 0; d < dim; ++d)
    if (!(reg.lo[d] <= reg.hi[d]))
      r.fail(v, p + ": min must be <= max on every axis (axis " + std::to_string(d) + ")");
}

void read_sphere(const Reader& r, const YAML::Node& v, const std::string& p, int dim, RegionSpec& reg) {
  const Fields f = r.check_keys(v, p, {"center", "radius"});
  reg.center = r.vector(r.require(f, "center", p + ".center"), p + ".center", dim);
  reg.radius = r.positive(r.require(f, "radius", p + ".radius"), p + ".radius");
}

void read_cylinder(const Reader& r, const YAML::Node& v, const std::string& p, int dim, RegionSpec& reg) {
  const Fields f = r.check_keys(v, p, {"center", "axis", "radius", "length"});
  reg.center = r.vector(r.require(f, "center", p + ".center"), p + ".center", dim);
  reg.axis_vector = r.nonzero_vector(r.require(f, "axis", p + ".axis"), p + ".axis", dim);
  reg.radius = r.positive(r.require(f, "radius", p + ".radius"), p + ".radius");
  if (const YAML::Node& l = f["length"]) reg.length = r.positive(l, p + ".length");
}

void read_label(const Reader& r, const YAML::Node& v, const std::string& p, int, RegionSpec& reg) {
  reg.label = r.string(v, p);
  if (reg.label.empty()) r.fail(v, p + " must name a label of the label image (its name or number)");
  // A number names its label already (a name is resolved by the run against the `labels:` table).
  if (reg.label.find_first_not_of("0123456789") == std::string::npos && reg.label.size() < 10)
    reg.label_value = std::stoi(reg.label);
}

// The region types, in the order messages list them (region_types() gives their names).
const RegionType kRegionTypes[] = {
    {"box_face", RegionSpec::Kind::box_face, read_box_face},
    {"box", RegionSpec::Kind::box, read_box},
    {"sphere", RegionSpec::Kind::sphere, read_sphere},
    {"cylinder", RegionSpec::Kind::cylinder, read_cylinder},
    {"label", RegionSpec::Kind::label, read_label},
};

RegionSpec parse_region(const Reader& r, const YAML::Node& n, const std::string& path, int dim) {
  const std::vector<std::string> names = region_types();
  r.check_keys(n, path, names);
  if (n.size() != 1) r.fail(n, path + " must have exactly one of: " + join(names));
  RegionSpec reg;
  const auto kv = *n.begin();
  const std::string kind = kv.first.Scalar();
  for (const RegionType& type : kRegionTypes)
    if (kind == type.name) {
      reg.kind = type.kind;
      type.read(r, kv.second, path + "." + kind, dim, reg);
    }
  return reg;
}

}  // namespace

std::vector<std::string> region_types() {
  std::vector<std::string> names;
  for (const RegionType& type : kRegionTypes) names.emplace_back(type.name);
  return names;
}

namespace {

// needle.friction of the kinematic model. Stick-slip is the default model (also when the key is
// absent); its limit max_shear_per_length has no default and is then required: the friction per unit
// length of shaft depends on the tissue, the needle and its surface, and published insertion
// measurements do not give one value to stand for them all (README, "Friction"). Pure stick is the
// no-slip limit, chosen with {model: stick}.
void parse_friction(const Reader& r, const Fields& f, const YAML::Node& needle, const std::string& path,
                    NeedleSpec& s) {
  const std::string fp = path + ".friction";
  const YAML::Node& fn = f["friction"];
  if (s.model == NeedleSpec::Model::force) {
    if (fn)
      r.fail(fn, fp + " applies only to needle model 'kinematic'; the force model takes friction_per_length");
    return;
  }
  const std::string required =
      fp +
      ".max_shear_per_length' (the stick-slip limit, force per unit length of shaft, "
      "> 0, e.g. mN/mm; it has no default); stick-slip is the default friction; "
      "use friction: {model: stick} for the no-slip limit";
  if (!fn) r.fail(needle, "missing key '" + required);
  const Fields fr = r.check_keys(fn, fp, {"model", "max_shear_per_length"});
  if (fr["model"])
    s.friction = r.choice(fr["model"], fp + ".model", vim::needle::friction_law_names("kinematic")) == "stick"
                     ? NeedleSpec::Friction::stick
                     : NeedleSpec::Friction::stick_slip;
  else
    s.friction = NeedleSpec::Friction::stick_slip;
  if (s.friction == NeedleSpec::Friction::stick_slip) {
    if (!fr["max_shear_per_length"]) r.fail(fn, "missing key '" + required);
    s.max_shear_per_length = r.positive(fr["max_shear_per_length"], fp + ".max_shear_per_length");
  } else if (fr["max_shear_per_length"]) {
    r.fail(fr["max_shear_per_length"], fp + ".max_shear_per_length applies only to model stick-slip");
  }
}

// needle.tissues: [{region: REGION | {modulus: {min, max}}, cutting_force, max_shear_per_length, fit}].
void parse_tissues(const Reader& r, const YAML::Node& t, const std::string& path, int dim, NeedleSpec& s) {
  if (s.model == NeedleSpec::Model::force)
    r.fail(t, path + " applies only to needle model 'kinematic' (cutting_force, max_shear_per_length)");
  if (!t.IsSequence() || t.size() == 0)
    r.fail(t, path + " must be a non-empty list of {region, cutting_force, max_shear_per_length, fit}");
  for (std::size_t i = 0; i < t.size(); ++i) {
    const std::string p = path + "[" + std::to_string(i) + "]";
    const Fields f = r.check_keys(t[i], p, {"region", "cutting_force", "max_shear_per_length", "fit"});
    TissueSpec ts;
    ts.line = Reader::line(t[i]);
    const YAML::Node& reg = f["region"];
    if (!reg)
      r.fail(t[i], "missing key '" + p + ".region' (a scenario region or {modulus: {min: A, max: B}})");
    if (reg.IsMap() && reg["modulus"]) {
      std::vector<std::string> names = region_types();
      names.emplace_back("modulus");
      r.check_keys(reg, p + ".region", names);
      if (reg.size() != 1) r.fail(reg, p + ".region must have exactly one of: " + join(names));
      const std::string mp = p + ".region.modulus";
      const Fields m = r.check_keys(reg["modulus"], mp, {"min", "max"});
      ts.modulus_min = r.number(r.require(m, "min", mp + ".min"), mp + ".min");
      ts.modulus_max = r.number(r.require(m, "max", mp + ".max"), mp + ".max");
      if (!(ts.modulus_min >= 0.0 && ts.modulus_min <= ts.modulus_max))
        r.fail(reg, mp + " must have 0 <= min <= max, got [" + number_text(ts.modulus_min) + ", " +
                        number_text(ts.modulus_max) + "]");
    } else {
      ts.region = parse_region(r, reg, p + ".region", dim);
    }
    for (const char* k : {"cutting_force", "max_shear_per_length"}) {
      const YAML::Node& x = f[k];
      if (!x) continue;
      const bool shear = std::string(k) == "max_shear_per_length";
      if (shear && s.friction != NeedleSpec::Friction::stick_slip)
        r.fail(x, p + ".max_shear_per_length applies only to friction model stick-slip");
      const double v = r.number(x, p + "." + k);
      if (!(v >= 0.0)) r.fail(x, p + "." + k + " must be >= 0, got " + number_text(v));
      (shear ? ts.max_shear_per_length : ts.cutting_force) = v;
    }
    if (!ts.cutting_force && !ts.max_shear_per_length)
      r.fail(t[i], p + " gives neither cutting_force nor max_shear_per_length; give at least one");
    if (const YAML::Node& x = f["fit"]) ts.fit = r.boolean(x, p + ".fit");
    s.tissues.push_back(std::move(ts));
  }
}

// extra_keys: keys the caller reads itself (a procedure's insertion: stay, seeds).
NeedleSpec parse_needle(const Reader& r, const YAML::Node& n, const std::string& path, int dim,
                        const std::vector<std::string>& extra_keys = {}) {
  // clang-format off
  std::vector<std::string> keys{"name", "entry", "direction", "depth", "steps", "diameter", "model", "friction",
      "sample_spacing", "cutting_distance", "cutting_force", "coupling_radius", "tip_force", "friction_per_length",
      "tissues", "fit", "flexible", "bevel", "rotations"};
  // clang-format on
  keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
  const Fields f = r.check_keys(n, path, keys);
  NeedleSpec s;
  s.line = Reader::line(n);
  if (f["name"]) {
    s.name = r.string(f["name"], path + ".name");
    if (!is_folder_name(s.name))
      r.fail(f["name"], path + ".name = '" + s.name +
                            "' must use only letters, digits, '_' and '-' (it names a folder)");
  }
  s.entry = r.vector(r.require(f, "entry", path + ".entry"), path + ".entry", dim);
  s.direction = r.nonzero_vector(r.require(f, "direction", path + ".direction"), path + ".direction", dim);
  s.depth = r.positive(r.require(f, "depth", path + ".depth"), path + ".depth");
  {
    const YAML::Node& st = r.require(f, "steps", path + ".steps");
    const long steps = r.integer(st, path + ".steps");
    if (steps <= 0) r.fail(st, path + ".steps must be > 0, got " + std::to_string(steps));
    if (steps > 1000000) r.fail(st, path + ".steps must be <= 1000000, got " + std::to_string(steps));
    s.steps = static_cast<int>(steps);
  }
  s.diameter = r.positive(r.require(f, "diameter", path + ".diameter"), path + ".diameter");
  if (f["model"])
    s.model = r.choice(f["model"], path + ".model", {"kinematic", "force"}) == "force"
                  ? NeedleSpec::Model::force
                  : NeedleSpec::Model::kinematic;
  parse_friction(r, f, n, path, s);
  if (f["sample_spacing"]) {
    s.sample_spacing = r.positive(f["sample_spacing"], path + ".sample_spacing");
    // One embedded point (one constraint of the FEM solve) per sample_spacing of travel.
    if (s.depth / s.sample_spacing > 100000.0)
      r.fail(f["sample_spacing"], path + ".sample_spacing = " + number_text(s.sample_spacing) +
                                      " puts more than 100000 shaft points "
                                      "on the depth of " +
                                      number_text(s.depth) + "; use at least " +
                                      number_text(s.depth / 100000.0));
  }
  if (const YAML::Node& c = f["cutting_distance"]) {
    // The force model loads the newest shaft point with the tip force: with a cutting distance there
    // would be no point, hence no tip force at all, until the tip had travelled that far.
    if (s.model == NeedleSpec::Model::force)
      r.fail(
          c,
          path +
              ".cutting_distance applies only to needle model 'kinematic'; the force model applies tip_force "
              "at the tissue the tip has reached");
    s.cutting_distance = r.number(c, path + ".cutting_distance");
    if (s.cutting_distance < 0.0)
      r.fail(c, path + ".cutting_distance must be >= 0, got " + number_text(s.cutting_distance));
    if (s.cutting_distance >= s.depth)
      r.fail(c, path + ".cutting_distance must be less than the depth (" + number_text(s.depth) + ")");
  }
  if (const YAML::Node& c = f["cutting_force"]) {
    if (s.model == NeedleSpec::Model::force)
      r.fail(
          c,
          path + ".cutting_force applies only to needle model 'kinematic'; the force model takes tip_force");
    s.cutting_force = r.number(c, path + ".cutting_force");
    if (!(s.cutting_force >= 0.0) || !std::isfinite(s.cutting_force))
      r.fail(c, path + ".cutting_force must be a finite force >= 0, got " + number_text(s.cutting_force));
  }
  if (const YAML::Node& c = f["coupling_radius"]) {
    s.coupling_radius = r.positive(c, path + ".coupling_radius");
    if (s.coupling_radius < 0.5 * s.diameter)
      r.fail(c, path + ".coupling_radius = " + number_text(s.coupling_radius) +
                    " must be at least the needle radius " + number_text(0.5 * s.diameter) +
                    " (diameter / 2)");
  }
  const bool force = s.model == NeedleSpec::Model::force;
  for (const char* k : {"tip_force", "friction_per_length"}) {
    const YAML::Node& x = f[k];
    if (!x) continue;
    if (!force) r.fail(x, path + "." + k + " applies only to needle model 'force'");
    const double v = r.number(x, path + "." + k);
    if (v < 0.0) r.fail(x, path + "." + k + " must be >= 0, got " + number_text(v));
    (std::string(k) == "tip_force" ? s.tip_force : s.friction_per_length) = v;
  }
  if (force && !(s.tip_force > 0.0 || s.friction_per_length > 0.0))
    r.fail(n, path + ": needle model 'force' needs tip_force and/or friction_per_length > 0");
  if (const YAML::Node& x = f["fit"]) s.fit = r.boolean(x, path + ".fit");
  if (const YAML::Node& t = f["tissues"]) parse_tissues(r, t, path + ".tissues", dim, s);
  if (const YAML::Node& x = f["flexible"]) parse_needle_flexible(r.scenario(), x, path + ".flexible", dim, s);
  if (f["bevel"] || f["rotations"]) parse_needle_bevel(r.scenario(), f["bevel"], f["rotations"], path, s);
  return s;
}

}  // namespace

std::string RegionSpec::describe() const {
  std::ostringstream s;
  auto v = [](const std::vector<double>& x) {
    std::ostringstream o;
    o << "[";
    for (std::size_t i = 0; i < x.size(); ++i) o << (i ? ", " : "") << x[i];
    o << "]";
    return o.str();
  };
  switch (kind) {
    case Kind::box_face:
      s << "box_face " << face;
      break;
    case Kind::box:
      s << "box " << v(lo) << ".." << v(hi);
      break;
    case Kind::sphere:
      s << "sphere center " << v(center) << " radius " << radius;
      break;
    case Kind::cylinder:
      s << "cylinder center " << v(center) << " axis " << v(axis_vector) << " radius " << radius;
      if (length > 0.0) s << " length " << length;
      break;
    case Kind::label:
      s << "label " << label;
      break;
  }
  return s.str();
}

std::string TissueSpec::describe() const {
  return region ? region->describe()
                : "modulus " + number_text(modulus_min) + ".." + number_text(modulus_max);
}

bool Scenario::wants(const std::string& field) const {
  return std::find(output_fields.begin(), output_fields.end(), field) != output_fields.end();
}

std::string Scenario::where(int line) const {
  return line > 0 ? source + ":" + std::to_string(line) + ": " : source + ": ";
}

namespace {

// material: the model, the modulus (from the image or constant, scale, clamp) and Poisson ratio.
void parse_material(const Reader& r, const Fields& top, Scenario& s) {
  if (const YAML::Node& m = top["material"]) {
    const Fields f =
        r.check_keys(m, "material", {"model", "youngs_modulus", "scale", "clamp", "poisson_ratio"});
    if (const YAML::Node& x = f["model"]) {
      s.material_model = r.choice(x, "material.model", {"linear", "neo-hookean"}) == "neo-hookean"
                             ? Scenario::MaterialModel::neo_hookean
                             : Scenario::MaterialModel::linear;
      s.material_model_line = x.Mark().line + 1;
    }
    if (const YAML::Node& e = f["youngs_modulus"]) {
      if (e.IsScalar() && e.Scalar() == "image") {
        s.modulus_from_image = true;
      } else {
        if (!e.IsScalar())
          r.fail(e, "material.youngs_modulus must be 'image' or a number > 0, got " + scalar_text(e));
        double v = 0.0;
        try {
          v = e.as<double>();
        } catch (const YAML::Exception&) {
          r.fail(e, "material.youngs_modulus must be 'image' or a number > 0, got " + scalar_text(e));
        }
        if (!(v > 0.0) || !std::isfinite(v))
          r.fail(e, "material.youngs_modulus must be 'image' or a number > 0, got " + number_text(v));
        s.modulus_from_image = false;
        s.youngs_modulus = v;
      }
    }
    if (const YAML::Node& x = f["scale"]) {
      s.scale = r.positive(x, "material.scale");
      if (!s.modulus_from_image && s.scale != 1.0)
        r.fail(x,
               "material.scale applies only to youngs_modulus: image (it converts the image's values); with "
               "a constant youngs_modulus give the modulus itself and remove scale");
    }
    if (const YAML::Node& c = f["clamp"]) {
      if (!c.IsSequence() || c.size() != 2)
        r.fail(c, "material.clamp must be a list [min, max], got " + scalar_text(c));
      const double lo = r.number(c[0], "material.clamp[0]"), hi = r.number(c[1], "material.clamp[1]");
      if (!(lo > 0.0))
        r.fail(c, "material.clamp min must be > 0 (a Young's modulus), got " + number_text(lo));
      if (!(hi >= lo))
        r.fail(c,
               "material.clamp must have min <= max, got [" + number_text(lo) + ", " + number_text(hi) + "]");
      s.clamp = std::make_pair(lo, hi);
    }
    if (const YAML::Node& nu = f["poisson_ratio"]) {
      const double v = r.number(nu, "material.poisson_ratio");
      if (v >= 0.5)
        r.fail(
            nu,
            "material.poisson_ratio = " + number_text(v) +
                " is not valid: it must be < 0.5 (0.5 is incompressible; use e.g. 0.49 with mesh.degree 2)");
      if (!(v > -1.0))
        r.fail(nu, "material.poisson_ratio = " + number_text(v) + " is not valid: it must be in (-1, 0.5)");
      s.poisson_ratio = v;
    }
  }
}

// mesh: the keys that set mesher options unless the command line does, and needle_refinement.
void parse_mesh(const Reader& r, const Fields& top, Scenario& s) {
  if (const YAML::Node& m = top["mesh"]) {
    const Fields f =
        r.check_keys(m, "mesh", {"nodes", "lambda", "degree", "min_dihedral", "needle_refinement"});
    if (const YAML::Node& x = f["nodes"]) {
      const long v = r.integer(x, "mesh.nodes");
      if (v < 8) r.fail(x, "mesh.nodes must be >= 8, got " + std::to_string(v));
      s.nodes = v;
    }
    if (const YAML::Node& x = f["lambda"]) {
      const double v = r.number(x, "mesh.lambda");
      if (!(v >= 0.0 && v < 1.0)) r.fail(x, "mesh.lambda must be in [0, 1), got " + number_text(v));
      s.lambda = v;
    }
    if (const YAML::Node& x = f["degree"]) {
      const long v = r.integer(x, "mesh.degree");
      if (v != 1 && v != 2) r.fail(x, "mesh.degree must be 1 or 2, got " + std::to_string(v));
      s.degree = static_cast<unsigned>(v);
    }
    if (const YAML::Node& x = f["min_dihedral"]) {
      const double v = r.number(x, "mesh.min_dihedral");
      if (!(v >= 0.0 && v < 60.0))
        r.fail(x, "mesh.min_dihedral must be in [0, 60) degrees (0 = off; e.g. 10), got " + number_text(v));
      s.min_dihedral = v;
    }
    if (const YAML::Node& x = f["needle_refinement"]) {
      const Fields g = r.check_keys(x, "mesh.needle_refinement", {"size_ratio", "radius"});
      Scenario::NeedleRefinement nr;
      const YAML::Node& ratio = r.require(g, "size_ratio", "mesh.needle_refinement.size_ratio");
      nr.size_ratio = r.number(ratio, "mesh.needle_refinement.size_ratio");
      if (!(nr.size_ratio > 0.0 && nr.size_ratio <= 1.0))
        r.fail(ratio,
               "mesh.needle_refinement.size_ratio must be in (0, 1] (element size on the needle path / "
               "far from it, e.g. 0.5), got " +
                   number_text(nr.size_ratio));
      nr.radius = r.positive(r.require(g, "radius", "mesh.needle_refinement.radius"),
                             "mesh.needle_refinement.radius");
      s.needle_refinement = nr;
    }
  }
}

// A fixed condition's `support:` at `sp`: nodes, or an elastic foundation {elastic: {stiffness, spacing}}.
void parse_support(const Reader& r, const YAML::Node& sn, const std::string& sp, BoundaryConditionSpec& bc) {
  if (bc.type != BoundaryConditionSpec::Type::fixed || bc.region.kind == RegionSpec::Kind::box_face ||
      bc.region.kind == RegionSpec::Kind::label)
    r.fail(sn, sp + " applies only to type fixed on a volume region (box, sphere, cylinder)");
  if (sn.IsScalar()) {
    const std::string v = r.choice(sn, sp, {"nodes", "elastic"});
    if (v == "elastic")
      r.fail(sn, sp + ": elastic needs a stiffness, e.g. {elastic: {stiffness: 15}} (modulus per length^2)");
    return;
  }
  const Fields sf = r.check_keys(sn, sp, {"elastic"});
  const Fields ef =
      r.check_keys(r.require(sf, "elastic", sp + ".elastic"), sp + ".elastic", {"stiffness", "spacing"});
  bc.support = BoundaryConditionSpec::Support::elastic;
  bc.support_stiffness =
      r.positive(r.require(ef, "stiffness", sp + ".elastic.stiffness"), sp + ".elastic.stiffness");
  if (const YAML::Node& h = ef["spacing"]) bc.support_spacing = r.positive(h, sp + ".elastic.spacing");
}

// boundary_conditions: at least one that holds the model (fixed or displacement).
void parse_boundary_conditions(const Reader& r, const Fields& top, Scenario& s, int dim) {
  {
    const YAML::Node& bcs = r.require(top, "boundary_conditions", "boundary_conditions");
    if (!bcs.IsSequence() || bcs.size() == 0)
      r.fail(bcs,
             "boundary_conditions must be a non-empty list (at least one fixed or displacement condition)");
    for (std::size_t i = 0; i < bcs.size(); ++i) {
      const std::string p = "boundary_conditions[" + std::to_string(i) + "]";
      const YAML::Node b = bcs[i];
      const Fields f = r.check_keys(b, p, {"type", "region", "value", "components", "support"});
      BoundaryConditionSpec bc;
      bc.line = Reader::line(b);
      const std::string t = r.choice(r.require(f, "type", p + ".type"), p + ".type",
                                     {"fixed", "displacement", "pressure", "traction"});
      bc.type = t == "fixed"          ? BoundaryConditionSpec::Type::fixed
                : t == "displacement" ? BoundaryConditionSpec::Type::displacement
                : t == "pressure"     ? BoundaryConditionSpec::Type::pressure
                                      : BoundaryConditionSpec::Type::traction;
      bc.region = parse_region(r, r.require(f, "region", p + ".region"), p + ".region", dim);
      if (bc.type == BoundaryConditionSpec::Type::fixed) {
        if (f["value"]) r.fail(f["value"], p + ".value is not used by type fixed (use type displacement)");
      } else if (bc.type == BoundaryConditionSpec::Type::pressure) {
        bc.value = {r.number(r.require(f, "value", p + ".value"), p + ".value")};
      } else {
        bc.value = r.vector(r.require(f, "value", p + ".value"), p + ".value", dim);
      }
      if (const YAML::Node& sn = f["support"]) parse_support(r, sn, p + ".support", bc);
      bc.components.assign(dim, true);
      if (const YAML::Node& c = f["components"]) {
        if (bc.support == BoundaryConditionSpec::Support::elastic)
          r.fail(c, p + ".components cannot be combined with an elastic support");
        if (!bc.is_dirichlet())
          r.fail(c, p + ".components applies only to fixed and displacement conditions");
        if (!c.IsSequence() || c.size() == 0)
          r.fail(c,
                 p + ".components must be a non-empty list of axis names (x, y" + (dim == 3 ? ", z)" : ")"));
        bc.components.assign(dim, false);
        for (std::size_t k = 0; k < c.size(); ++k) {
          const std::string a = r.choice(
              c[k], p + ".components[" + std::to_string(k) + "]",
              dim == 3 ? std::vector<std::string>{"x", "y", "z"} : std::vector<std::string>{"x", "y"});
          bc.components[a[0] - 'x'] = true;
        }
      }
      s.boundary_conditions.push_back(bc);
    }
    bool dirichlet = false;
    for (const auto& bc : s.boundary_conditions) dirichlet = dirichlet || bc.is_dirichlet();
    if (!dirichlet)
      r.fail(
          bcs,
          "boundary_conditions has no 'fixed' or 'displacement' condition: the model would be free to move "
          "(singular); fix at least one region, e.g. {type: fixed, region: {box_face: y_min}}");
  }
}

// needle, or needles (a list with unique names).
void parse_needles(const Reader& r, const Fields& top, Scenario& s, int dim) {
  {
    const YAML::Node &one = top["needle"], &many = top["needles"], &procedure = top["procedure"];
    if (one && many) r.fail(many, "give either 'needle' or 'needles', not both");
    if (procedure && (one || many))
      r.fail(procedure, "give either 'procedure' or 'needle'/'needles', not both");
    if (procedure)
      return parse_procedure(procedure, s, [&](const YAML::Node& n, const std::string& path) {
        return parse_needle(r, n, path, dim, {"stay", "seeds"});
      });
    if (!one && !many) return;  // a static load case (check_static_load)
    if (one) {
      s.needles.push_back(parse_needle(r, one, "needle", dim));
    } else {
      s.needle_list = true;
      if (!many.IsSequence() || many.size() == 0)
        r.fail(many, "needles must be a non-empty list of needle mappings");
      std::set<std::string> names;
      for (std::size_t i = 0; i < many.size(); ++i) {
        NeedleSpec n = parse_needle(r, many[i], "needles[" + std::to_string(i) + "]", dim);
        if (!many[i]["name"]) n.name = "needle_" + std::to_string(i + 1);
        if (!names.insert(n.name).second)
          r.fail(many[i], "needles[" + std::to_string(i) + "].name = '" + n.name +
                              "' is used twice; names must be unique");
        s.needles.push_back(n);
      }
    }
  }
}

// Whether a condition moves the tissue: a prescribed displacement with a non-zero held component, or a
// non-zero pressure or traction.
bool is_load(const BoundaryConditionSpec& bc) {
  if (bc.type == BoundaryConditionSpec::Type::fixed) return false;
  for (std::size_t c = 0; c < bc.value.size(); ++c)
    if (bc.value[c] != 0.0 && (bc.type != BoundaryConditionSpec::Type::displacement || bc.components[c]))
      return true;
  return false;
}

// A scenario without a needle is a static load case (solved once, step 0): it needs a load, and
// mesh.needle_refinement has no path to refine along.
void check_static_load(const Reader& r, const Fields& top, const Scenario& s) {
  if (s.material_model == Scenario::MaterialModel::neo_hookean)
    for (const NeedleSpec& n : s.needles) {
      const auto refuse = [&](const std::string& what, const std::string& why, const std::string& key) {
        r.fail(top["material"]["model"], "material.model = 'neo-hookean' with " + what + ", line " +
                                             std::to_string(n.line) + ") is not built: " + why +
                                             "; use material.model: linear or remove " + key);
      };
      if (n.flexible)
        refuse("a flexible needle (needle.flexible", "the flexible needle runs on the linear model",
               "needle.flexible");
      if (n.stay)
        refuse("a needle left in the tissue (stay: true", "a staying needle is held on the linear model",
               "stay");
    }
  if (s.material_model == Scenario::MaterialModel::neo_hookean && s.probe && !s.probe->motions.empty())
    r.fail(top["material"]["model"], "material.model = 'neo-hookean' with a probe motion (procedure[" +
                                         std::to_string(s.probe->motions.front().action) + "], line " +
                                         std::to_string(s.probe->motions.front().line) +
                                         ") is not built: the probe moves its foundation's base as a load of "
                                         "the linear model; use material.model: linear or remove the motion");
  if (!s.needles.empty() || s.procedure) return;
  if (std::none_of(s.boundary_conditions.begin(), s.boundary_conditions.end(), is_load))
    r.fail(top["boundary_conditions"],
           "boundary_conditions: a scenario without 'needle' or 'needles' is a static load case, but no "
           "condition loads the model (only fixed supports or zero values: nothing would move); add a "
           "displacement with a non-zero value, a pressure or a traction, or a needle");
  if (const YAML::Node& m = top["mesh"])
    if (m["needle_refinement"])
      r.fail(m["needle_refinement"],
             "mesh.needle_refinement refines the mesh along the needle paths, but the scenario has no "
             "'needle' or 'needles'; remove it");
}

// targets: named points whose displacement is recorded.
void parse_targets(const Reader& r, const Fields& top, Scenario& s, int dim) {
  if (const YAML::Node& t = top["targets"]) {
    if (!t.IsSequence())
      r.fail(t, "targets must be a list of {name, position} or {name, label, at: centroid}");
    std::set<std::string> names;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const std::string p = "targets[" + std::to_string(i) + "]";
      const Fields f = r.check_keys(t[i], p, {"name", "position", "label", "at"});
      TargetSpec ts;
      ts.line = Reader::line(t[i]);
      const YAML::Node& nn = r.require(f, "name", p + ".name");
      ts.name = r.string(nn, p + ".name");
      if (!is_identifier(ts.name))
        r.fail(nn, p + ".name = '" + ts.name +
                       "' must be an identifier (letters, digits, '_'; it names CSV columns)");
      if (!names.insert(ts.name).second)
        r.fail(nn, p + ".name = '" + ts.name + "' is used twice; names must be unique");
      if (const YAML::Node& l = f["label"]) {  // the centroid of a label (docs/labels.md)
        if (f["position"])
          r.fail(f["position"], p + " has both position and label; give one (label: NAME, at: centroid)");
        ts.label = r.string(l, p + ".label");
        if (const YAML::Node& at = f["at"]) r.choice(at, p + ".at", {"centroid"});
      } else {
        if (const YAML::Node& at = f["at"]) r.fail(at, p + ".at goes with label (label: NAME, at: centroid)");
        ts.position = r.vector(r.require(f, "position", p + ".position"), p + ".position", dim);
      }
      s.targets.push_back(ts);
    }
  }
}

// output (step files, fields) and solver.
void parse_output_and_solver(const Reader& r, const Fields& top, Scenario& s) {
  if (const YAML::Node& o = top["output"]) {
    const Fields f = r.check_keys(o, "output", {"every", "fields"});
    if (const YAML::Node& x = f["every"]) {
      const long v = r.integer(x, "output.every");
      if (v < 0) r.fail(x, "output.every must be >= 0 (0 = no step files), got " + std::to_string(v));
      s.output_every = static_cast<int>(v);
    }
    if (const YAML::Node& l = f["fields"]) {
      if (!l.IsSequence()) r.fail(l, "output.fields must be a list");
      s.output_fields.clear();
      for (std::size_t i = 0; i < l.size(); ++i)
        s.output_fields.push_back(
            r.choice(l[i], "output.fields[" + std::to_string(i) + "]",
                     {"displacement", "strain", "stress", "von_mises", "youngs_modulus"}));
    }
  }

  if (const YAML::Node& v = top["solver"]) {
    const Fields f = r.check_keys(v, "solver", {"type", "tolerance"});
    if (const YAML::Node& x = f["type"])
      s.solver_type = r.choice(x, "solver.type", {"auto", "direct", "amg", "multigrid"});
    if (const YAML::Node& x = f["tolerance"]) s.solver_tolerance = r.positive(x, "solver.tolerance");
  }
}

}  // namespace

Scenario parse_scenario_text(const std::string& yaml_text, int dim, const std::string& source_name) {
  Scenario s;
  s.source = source_name;
  s.text = yaml_text;
  s.dim = dim;
  if (dim != 2 && dim != 3) throw ScenarioError(s.where(0) + "only 2D and 3D images are supported");
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ScenarioError(s.where(e.mark.line >= 0 ? e.mark.line + 1 : 0) + "YAML syntax error: " + e.msg);
  }
  const Reader r(s);
  if (!root || root.IsNull()) throw ScenarioError(s.where(0) + "the scenario file is empty");
  const Fields top = r.check_keys(root, "",
                                  {"units", "material", "mesh", "boundary_conditions", "needle", "needles",
                                   "procedure", "dose", "probe", "targets", "output", "solver", "labels"});

  if (const YAML::Node& u = top["units"]) {
    const Fields f = r.check_keys(u, "units", {"length", "modulus"});
    if (const YAML::Node& x = f["length"]) s.length_unit = r.string(x, "units.length");
    if (const YAML::Node& x = f["modulus"]) s.modulus_unit = r.string(x, "units.modulus");
  }

  parse_material(r, top, s);
  if (const YAML::Node& l = top["labels"]) parse_labels(l, s);
  parse_mesh(r, top, s);
  parse_boundary_conditions(r, top, s, dim);
  if (const YAML::Node& p = top["probe"])
    parse_probe(
        p, s, [&](const YAML::Node& n, const std::string& at) { return parse_region(r, n, at, dim); },
        [&](const YAML::Node& n, const std::string& at, BoundaryConditionSpec& bc) {
          parse_support(r, n, at, bc);
        });
  parse_needles(r, top, s, dim);
  check_static_load(r, top, s);
  if (const YAML::Node& d = top["dose"])
    parse_dose(d, s, [&](const YAML::Node& n, const std::string& p) { return parse_region(r, n, p, dim); });
  parse_targets(r, top, s, dim);
  parse_output_and_solver(r, top, s);
  return s;
}

std::string read_input_text(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw ScenarioError(path + ": cannot open the " + what);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

Scenario read_scenario(const std::string& path, int dim) {
  return parse_scenario_text(read_input_text(path, "scenario file"), dim, path);
}

}  // namespace vim::pipeline

// A scenario's `procedure:` (docs/procedure.md), its `probe:` and its `dose:` (docs/dose.md): an ordered
// list of one-key actions, `insert` (a needle as in `needles`, with stay and seeds), `withdraw` (a needle
// back out in steps) and `probe` (the probe translated or rotated in steps, ProbeMotionSpec). Each insertion
// becomes an entry of Scenario::needles, in order, with its seeds and its withdrawal; a needle not withdrawn
// by an action is withdrawn with its insertion's steps before the next action (stay: false); one with stay:
// true stays in, its stations holding the tissue for the later actions, to the end or to a `withdraw` of it
// (run after the insertions before that action).
#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>
#include <vim/pipeline/dose/tg43.hpp>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

namespace {

std::vector<double> read_seeds(const Reader& r, const YAML::Node& n, const std::string& path, double depth) {
  if (!n.IsSequence() || n.size() == 0)
    r.fail(n, path + " must be a non-empty list of depths along the needle's path, got " + scalar_text(n));
  std::vector<double> seeds;
  for (std::size_t j = 0; j < n.size(); ++j) {
    const std::string at = path + "[" + std::to_string(j) + "]";
    const double d = r.number(n[j], at);
    if (!(d > 0.0 && d <= depth))
      r.fail(n[j], at + " = " + number_text(d) + " must be a depth in (0, " + number_text(depth) +
                       "], the needle's depth");
    seeds.push_back(d);
  }
  std::sort(seeds.begin(), seeds.end());
  return seeds;
}

// A procedure's `probe:` action at `path`: {translate: [x, y, z] | rotate: DEG, steps: K}.
void parse_probe_motion(const Reader& r, const YAML::Node& n, const std::string& path, int action,
                        Scenario& s) {
  if (!s.probe)
    r.fail(n, path +
                  ": the scenario has no 'probe' to move; define it at the top level, e.g. probe: {region: "
                  "{cylinder: {center, axis, radius}}, support: {elastic: {stiffness: 15}}}");
  const Fields f = r.check_keys(n, path, {"translate", "rotate", "steps"});
  ProbeMotionSpec m;
  m.line = Reader::line(n);
  m.action = action;
  m.after = s.needles.size();
  const YAML::Node &t = f["translate"], &a = f["rotate"];
  if (t && a) r.fail(a, path + ": give either translate or rotate, not both (one motion per action)");
  if (!t && !a)
    r.fail(n, path + " needs translate: [x, y" + (s.dim == 3 ? ", z]" : "]") +
                  " (length units) or rotate: DEG (degrees about the probe's axis)");
  if (t) {
    m.translate = r.vector(t, path + ".translate", s.dim);
  } else {
    if (s.dim != 3) r.fail(a, path + ".rotate needs a 3D image (a rotation about the probe's axis)");
    m.rotate = r.number(a, path + ".rotate");
    if (!(std::abs(m.rotate) <= 90.0))
      r.fail(a, path + ".rotate = " + number_text(m.rotate) + " must be in [-90, 90] degrees");
  }
  const YAML::Node& st = r.require(f, "steps", path + ".steps");
  const long steps = r.integer(st, path + ".steps");
  if (steps <= 0 || steps > 1000000)
    r.fail(st, path + ".steps must be in 1..1000000, got " + std::to_string(steps));
  m.steps = static_cast<int>(steps);
  s.probe->motions.push_back(m);
}

}  // namespace

void parse_probe(
    const YAML::Node& probe, Scenario& s,
    const std::function<RegionSpec(const YAML::Node&, const std::string&)>& region,
    const std::function<void(const YAML::Node&, const std::string&, BoundaryConditionSpec&)>& support) {
  const Reader r(s);
  const Fields f = r.check_keys(probe, "probe", {"region", "support"});
  ProbeSpec p;
  p.line = Reader::line(probe);
  p.hold.line = p.line;
  const YAML::Node& reg = r.require(f, "region", "probe.region");
  p.hold.region = region(reg, "probe.region");
  if (p.hold.region.kind != RegionSpec::Kind::cylinder)
    r.fail(reg,
           "probe.region must be a cylinder (its axis is the probe's axis), got " + p.hold.region.describe());
  const YAML::Node& sup = r.require(f, "support", "probe.support");
  support(sup, "probe.support", p.hold);
  if (p.hold.support != BoundaryConditionSpec::Support::elastic)
    r.fail(sup,
           "probe.support must be an elastic foundation, e.g. {elastic: {stiffness: 15}} (modulus per "
           "length^2): the tissue is bonded to the probe through it");
  p.hold.components.assign(static_cast<std::size_t>(s.dim), true);
  s.probe = p;
}

void parse_procedure(const YAML::Node& procedure, Scenario& s,
                     const std::function<NeedleSpec(const YAML::Node&, const std::string&)>& needle) {
  const Reader r(s);
  if (!procedure.IsSequence() || procedure.size() == 0)
    r.fail(procedure, "procedure must be a non-empty list of actions (insert, withdraw, probe)");
  s.procedure = s.needle_list = true;
  std::set<std::string> names;
  std::size_t in = s.needles.size();  // the needle in the tissue (none: needles.size())
  bool seeds_released = false;        // an insertion before has seeds
  const auto withdraw_implicitly = [&] {
    if (in < s.needles.size()) s.needles[in].withdraw_steps = s.needles[in].steps;
    in = s.needles.size();
  };
  for (std::size_t i = 0; i < procedure.size(); ++i) {
    const std::string path = "procedure[" + std::to_string(i) + "]";
    const YAML::Node& action = procedure[i];
    if (!action.IsMap() || action.size() != 1)
      r.fail(action, path + " must be a mapping with one key, the action: insert, withdraw or probe");
    const Fields f = r.check_keys(action, path, {"insert", "withdraw", "probe"});
    if (const YAML::Node& n = f["probe"]) {
      withdraw_implicitly();  // the probe moves with only the needles left in
      parse_probe_motion(r, n, path + ".probe", static_cast<int>(i), s);
      continue;
    }
    if (const YAML::Node& n = f["insert"]) {
      withdraw_implicitly();
      const std::string at = path + ".insert";
      NeedleSpec spec = needle(n, at);
      if (!n["name"]) spec.name = "needle_" + std::to_string(s.needles.size() + 1);
      if (!names.insert(spec.name).second)
        r.fail(n, at + ".name = '" + spec.name + "' is used twice; names must be unique");
      if (const YAML::Node& stay = n["stay"]) {
        spec.stay = r.boolean(stay, at + ".stay");
        if (spec.stay && n["seeds"])
          r.fail(stay, at + ".stay = true with seeds: a needle left in releases no seeds (its later "
                            "withdrawal is not a seeding pass); leave out stay or seeds");
        if (spec.stay && seeds_released)
          r.fail(stay, at + ".stay = true after a needle that released seeds: a needle left in moves the "
                            "tissue those seeds are in; insert the needles that stay first");
      }
      if (const YAML::Node& seeds = n["seeds"]) spec.seeds = read_seeds(r, seeds, at + ".seeds", spec.depth);
      if (spec.model == NeedleSpec::Model::force)
        r.fail(n, at + ": a procedure's needles use the kinematic model (the force model has no withdrawal)");
      seeds_released = seeds_released || !spec.seeds.empty();
      const bool stays = spec.stay;
      s.needles.push_back(std::move(spec));
      in = stays ? s.needles.size() : s.needles.size() - 1;  // a needle that stays is never withdrawn
      continue;
    }
    const std::string at = path + ".withdraw";
    const YAML::Node& w = f["withdraw"];
    const Fields wf = r.check_keys(w, at, {"needle", "steps"});
    const YAML::Node& name_node = r.require(wf, "needle", at + ".needle");
    const std::string name = r.string(name_node, at + ".needle");
    const auto it =
        std::find_if(s.needles.begin(), s.needles.end(), [&](const NeedleSpec& n) { return n.name == name; });
    if (it == s.needles.end()) {
      std::string known;
      for (const NeedleSpec& n : s.needles) known += (known.empty() ? "" : ", ") + n.name;
      r.fail(name_node, at + ".needle = '" + name + "' names no needle inserted before it (inserted: " +
                            (known.empty() ? "none" : known) + ")");
    }
    if (it->stay) {
      if (it->withdraw_action >= 0)
        r.fail(name_node, at + ".needle = '" + name +
                              "' is not in the tissue (it was withdrawn before, on line " +
                              std::to_string(it->withdraw_line) + ")");
      if (it->flexible)
        r.fail(name_node, at + ".needle = '" + name + "' is a flexible needle left in (stay: true, line " +
                              std::to_string(it->line) +
                              "): withdrawing it after other actions is built for the rigid needle only");
      withdraw_implicitly();  // a needle in since the last action comes out first
      it->withdraw_action = static_cast<int>(i);
      it->withdraw_after = s.needles.size();
    } else if (static_cast<std::size_t>(it - s.needles.begin()) != in)
      r.fail(name_node, at + ".needle = '" + name + "' is not in the tissue (it was withdrawn before" +
                            (it->withdraw_line > 0 ? ", on line " + std::to_string(it->withdraw_line) : "") +
                            ")");
    const YAML::Node& st = r.require(wf, "steps", at + ".steps");
    const long steps = r.integer(st, at + ".steps");
    if (steps <= 0 || steps > 1000000)
      r.fail(st, at + ".steps must be in 1..1000000, got " + std::to_string(steps));
    it->withdraw_steps = static_cast<int>(steps);
    it->withdraw_line = Reader::line(w);
    if (!it->stay) in = s.needles.size();
  }
  withdraw_implicitly();
}

void parse_dose(const YAML::Node& dose, Scenario& s,
                const std::function<RegionSpec(const YAML::Node&, const std::string&)>& region) {
  const Reader r(s);
  const Fields f =
      r.check_keys(dose, "dose", {"seed_model", "air_kerma_strength", "prescription", "grid", "region"});
  if (s.dim != 3) r.fail(dose, "dose needs a 3D image (the TG-43 dose is that of points in space)");
  if (!s.procedure)
    r.fail(dose, "dose needs a 'procedure' with seeds (it is the dose of their planned and final positions)");
  DoseSpec d;
  d.line = Reader::line(dose);
  const YAML::Node& model = r.require(f, "seed_model", "dose.seed_model");
  d.seed_model = r.string(model, "dose.seed_model");
  try {
    dose::seed_model(d.seed_model);
  } catch (const InputError& e) {
    r.fail(model, std::string("dose.seed_model: ") + e.what());
  }
  d.air_kerma_strength =
      r.positive(r.require(f, "air_kerma_strength", "dose.air_kerma_strength"), "dose.air_kerma_strength");
  if (const YAML::Node& p = f["prescription"]) d.prescription = r.positive(p, "dose.prescription");
  d.grid = r.positive(r.require(f, "grid", "dose.grid"), "dose.grid");
  const YAML::Node& reg = r.require(f, "region", "dose.region");
  d.region = region(reg, "dose.region");
  if (d.region.kind == RegionSpec::Kind::box_face)
    r.fail(reg, "dose.region must be a volume (box, sphere, cylinder or label), not a box face");
  if (s.length_unit != "mm")
    r.fail(dose,
           "dose needs lengths in mm (units.length = '" + s.length_unit + "'): the TG-43 tables are in cm");
  s.dose = d;
}

}  // namespace vim::pipeline

// The values --fit-forces adjusts and the scenario with fitted values (force_fit.hpp).
#include <yaml-cpp/yaml.h>

#include <vim/pipeline/fit/force_fit.hpp>

namespace vim::pipeline {

namespace {

const char* key_of(FitParameter::Kind kind) {
  return kind == FitParameter::Kind::cutting_force ? "cutting_force" : "max_shear_per_length";
}

}  // namespace

std::vector<FitParameter> fit_parameters(const Scenario& s) {
  if (s.needles.size() != 1)
    throw ScenarioError(s.where(s.needles.empty() ? 0 : s.needles[1].line) +
                        "--fit-forces fits one needle's force-depth curve; the scenario has " +
                        std::to_string(s.needles.size()) + " needles (give one 'needle')");
  const NeedleSpec& n = s.needles.front();
  const std::string path = s.needle_list ? "needles[0]" : "needle";
  std::vector<FitParameter> out;
  const auto add = [&](FitParameter::Kind kind, int tissue, double value) {
    if (!(value > 0.0)) return;
    FitParameter p;
    p.kind = kind;
    p.tissue = tissue;
    p.name = path + (tissue < 0 ? "" : ".tissues[" + std::to_string(tissue) + "]") +
             (kind == FitParameter::Kind::max_shear_per_length && tissue < 0 ? ".friction." : ".") +
             key_of(kind);
    p.start = p.value = value;
    out.push_back(p);
  };
  if (n.fit) {
    add(FitParameter::Kind::cutting_force, -1, n.cutting_force);
    add(FitParameter::Kind::max_shear_per_length, -1, n.max_shear_per_length);
  }
  for (std::size_t i = 0; i < n.tissues.size(); ++i) {
    const TissueSpec& t = n.tissues[i];
    if (!t.fit) continue;
    add(FitParameter::Kind::cutting_force, static_cast<int>(i), t.cutting_force.value_or(0.0));
    add(FitParameter::Kind::max_shear_per_length, static_cast<int>(i), t.max_shear_per_length.value_or(0.0));
  }
  if (out.empty())
    throw ScenarioError(
        s.where(n.line) + path +
        ": --fit-forces has nothing to fit: no cutting_force or max_shear_per_length > 0 of the "
        "needle or of a needle.tissues entry has fit: true; set fit: true (the default) on one");
  return out;
}

Scenario with_parameters(const Scenario& s, const std::vector<FitParameter>& parameters) {
  YAML::Node root = YAML::Load(s.text);
  YAML::Node needle = s.needle_list ? root["needles"][0] : root["needle"];
  for (const FitParameter& p : parameters) {
    YAML::Node at = p.tissue < 0 ? needle : needle["tissues"][static_cast<std::size_t>(p.tissue)];
    if (p.tissue < 0 && p.kind == FitParameter::Kind::max_shear_per_length)
      needle["friction"]["max_shear_per_length"] = p.value;
    else
      at[key_of(p.kind)] = p.value;
  }
  YAML::Emitter e;
  e << root;
  return parse_scenario_text(std::string(e.c_str()) + "\n", s.dim, s.source);
}

}  // namespace vim::pipeline

// Reading a study file (study.hpp): the base scenario, the list cases and the grid, combined into
// cases whose scenarios are the base's YAML with the varied values put in and then read by the
// scenario parser, so a case is checked by exactly the rules of --simulate. Errors name the study
// file, the line and the key (the scenario reader's style, scenario_reader.hpp).
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vim/pipeline/study/study.hpp>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

const std::vector<StudyKey>& study_keys() {
  static const std::vector<StudyKey> keys = {
      {"entry", "needle.entry"},
      {"direction", "needle.direction"},
      {"depth", "needle.depth"},
      {"scale", "material.scale"},
      {"poisson_ratio", "material.poisson_ratio"},
      {"max_shear_per_length", "needle.friction.max_shear_per_length"}};
  return keys;
}

std::optional<ActionKey> action_key(const std::string& key) {
  const std::string head = "procedure[";
  if (key.rfind(head, 0) != 0) return std::nullopt;
  const std::size_t close = key.find("].", head.size());
  if (close == std::string::npos || close == head.size() || close - head.size() > 6) return std::nullopt;
  const std::string digits = key.substr(head.size(), close - head.size());
  if (!std::all_of(digits.begin(), digits.end(), is_digit)) return std::nullopt;
  const std::string name = key.substr(close + 2);
  for (const char* k : {"entry", "direction", "depth", "seeds", "translate", "rotate"})
    if (name == k) return ActionKey{std::stoul(digits), name};
  return std::nullopt;
}

namespace {

constexpr std::size_t kMaxCases = 100000;

std::vector<std::string> key_names() {
  std::vector<std::string> names;
  for (const auto& k : study_keys()) names.emplace_back(k.name);
  return names;
}

std::string scenario_key(const std::string& key) {
  for (const auto& k : study_keys())
    if (key == k.name) return k.scenario_key;
  return key;
}

bool is_vector_key(const std::string& key) {
  const std::optional<ActionKey> a = action_key(key);
  const std::string k = a ? a->key : key;
  return k == "entry" || k == "direction" || (a && k == "translate");
}
bool is_needle_key(const std::string& key) { return key != "scale" && key != "poisson_ratio"; }

// The keys a cases entry or the grid may give: the study keys and the action keys among n's keys (any
// other key is refused with the study keys and the action-key pattern as the valid ones).
std::vector<std::string> valid_keys(const YAML::Node& n) {
  std::vector<std::string> valid = key_names();
  if (n.IsMap())
    for (const auto& kv : n)
      if (kv.first.IsScalar() && action_key(kv.first.Scalar())) valid.push_back(kv.first.Scalar());
  valid.emplace_back(kActionKeyPattern);
  return valid;
}

// One varied value as written in the study file.
struct Value {
  std::string key;
  YAML::Node node;
};

// A value's text for messages and study.csv's case description: "20" or "[-30, -5, 3]".
std::string value_text(const YAML::Node& n) {
  if (n.IsScalar()) return n.Scalar();
  std::string s = "[";
  for (std::size_t i = 0; i < n.size(); ++i) s += (i ? ", " : "") + n[i].Scalar();
  return s + "]";
}

// A number, for entry/direction/translate a list of dim numbers, for seeds a non-empty list of numbers
// (the scenario parser checks the ranges).
void check_value(const Reader& r, const std::string& key, const YAML::Node& n, const std::string& path,
                 int dim) {
  const std::optional<ActionKey> a = action_key(key);
  if (is_vector_key(key)) {
    r.vector(n, path, dim);
  } else if (a && a->key == "seeds") {
    if (!n.IsSequence() || n.size() == 0)
      r.fail(n, path + " must be a non-empty list of depths, got " + scalar_text(n));
    for (std::size_t i = 0; i < n.size(); ++i) r.number(n[i], path + "[" + std::to_string(i) + "]");
  } else {
    r.number(n, path);
  }
}

struct ListCase {
  std::string name;
  std::vector<Value> values;
};

std::vector<ListCase> parse_cases(const Reader& r, const YAML::Node& n, int dim) {
  if (!n.IsSequence() || n.size() == 0)
    r.fail(n, "cases must be a non-empty list of case mappings, got " + scalar_text(n));
  std::vector<ListCase> cases;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string path = "cases[" + std::to_string(i) + "]";
    std::vector<std::string> keys = valid_keys(n[i]);
    keys.insert(keys.begin(), "name");
    const Fields f = r.check_keys(n[i], path, keys);
    ListCase c;
    c.name = "case-" + std::to_string(i + 1);
    if (const YAML::Node& name = f["name"]) {
      c.name = r.string(name, path + ".name");
      if (!is_folder_name(c.name))
        r.fail(name, path + ".name = '" + c.name + "' must be a folder name of letters, digits, '_' and '-'");
      for (const ListCase& other : cases)
        if (other.name == c.name) r.fail(name, path + ".name = '" + c.name + "' is given to two cases");
    }
    for (const auto& key : key_names())
      if (const YAML::Node& v = f[key.c_str()]) {
        check_value(r, key, v, path + "." + key, dim);
        c.values.push_back({key, v});
      }
    for (const auto& kv : n[i])
      if (action_key(kv.first.Scalar())) {
        check_value(r, kv.first.Scalar(), kv.second, path + "." + kv.first.Scalar(), dim);
        c.values.push_back({kv.first.Scalar(), kv.second});
      }
    cases.push_back(std::move(c));
  }
  return cases;
}

struct GridAxis {
  std::string key;
  YAML::Node values;  // a non-empty sequence
};

// The grid's keys in the order written (the first varies slowest).
std::vector<GridAxis> parse_grid(const Reader& r, const YAML::Node& n, int dim) {
  r.check_keys(n, "grid", valid_keys(n));
  std::vector<GridAxis> axes;
  for (const auto& kv : n) {
    const std::string key = kv.first.Scalar(), path = "grid." + key;
    if (!kv.second.IsSequence() || kv.second.size() == 0)
      r.fail(kv.second, path + " must be a non-empty list of values, got " + scalar_text(kv.second));
    for (std::size_t i = 0; i < kv.second.size(); ++i)
      check_value(r, key, kv.second[i], path + "[" + std::to_string(i) + "]", dim);
    axes.push_back({key, kv.second});
  }
  if (axes.empty()) r.fail(n, "grid must vary at least one of: " + join(key_names()));
  return axes;
}

// An action key's value put into the base scenario's procedure: the action must exist and have the key
// (insert: entry, direction, depth, seeds; probe: translate or rotate, the other one removed).
void set_action_value(const Reader& r, YAML::Node& root, const std::string& base_path, const ActionKey& a,
                      const YAML::Node& value) {
  const YAML::Node& base = root;  // const: looking up does not add keys
  const YAML::Node& procedure = base["procedure"];
  const std::string at = "procedure[" + std::to_string(a.index) + "]";
  if (!procedure || !procedure.IsSequence() || a.index >= procedure.size())
    r.fail(value, at + "." + a.key + " varies an action of a procedure, but " + base_path +
                      (procedure && procedure.IsSequence()
                           ? " has " + std::to_string(procedure.size()) + " actions (numbered from 0)"
                           : " has no 'procedure' list"));
  YAML::Node action = procedure[a.index];
  if (!action.IsMap() || action.size() != 1) return;  // the scenario parser names it
  const std::string name = action.begin()->first.Scalar();
  const bool insert_key = a.key == "entry" || a.key == "direction" || a.key == "depth" || a.key == "seeds";
  const bool probe_key = a.key == "translate" || a.key == "rotate";
  if (!((name == "insert" && insert_key) || (name == "probe" && probe_key)))
    r.fail(value, at + "." + a.key + ": " + at + " of " + base_path + " is a '" + name +
                      "' action, which has no " + a.key +
                      " to vary (insert: entry, direction, depth, seeds; probe: translate, rotate)");
  YAML::Node body = action.begin()->second;
  if (probe_key) body.remove(a.key == "translate" ? "rotate" : "translate");
  body[a.key] = YAML::Clone(value);
}

// The base scenario's YAML with `values` put in.
YAML::Node apply_values(const Reader& r, const YAML::Node& base_root, const std::string& base_path,
                        const std::vector<Value>& values) {
  YAML::Node root = YAML::Clone(base_root);
  for (const Value& v : values) {
    if (const std::optional<ActionKey> a = action_key(v.key)) {
      set_action_value(r, root, base_path, *a, v.node);
      continue;
    }
    if (!is_needle_key(v.key)) {
      if (!root["material"]) root["material"] = YAML::Node(YAML::NodeType::Map);
      root["material"][v.key] = YAML::Clone(v.node);
      continue;
    }
    if (root["needles"])
      r.fail(v.node, v.key + " varies the needle, but " + base_path +
                         " has a 'needles' list; a study varies a scenario with one 'needle'");
    if (!root["needle"]) r.fail(v.node, v.key + " varies the needle, but " + base_path + " has no 'needle'");
    YAML::Node needle = root["needle"];
    if (v.key == "max_shear_per_length") {
      YAML::Node friction(YAML::NodeType::Map);
      friction["model"] = "stick-slip";
      friction["max_shear_per_length"] = YAML::Clone(v.node);
      needle["friction"] = friction;
    } else {
      needle[v.key] = YAML::Clone(v.node);
    }
  }
  return root;
}

// "FILE:LINE: message" or "FILE: message" → "message".
std::string without_location(const std::string& message, const std::string& file) {
  if (message.rfind(file + ":", 0) != 0) return message;
  std::size_t i = file.size() + 1;
  while (i < message.size() && is_digit(message[i])) ++i;
  if (i < message.size() && message[i] == ':') ++i;
  while (i < message.size() && message[i] == ' ') ++i;
  return message.substr(i);
}

std::string describe(const std::vector<Value>& values) {
  std::string s;
  for (const Value& v : values) s += (s.empty() ? "" : ", ") + v.key + " = " + value_text(v.node);
  return s.empty() ? "no value varied" : s;
}

// One case: the scenario text (a comment line, then the YAML) read by the scenario parser. Its errors
// are given at the line of the varied value they name (the first value otherwise).
StudyCase make_case(const Reader& r, const Study& study, const YAML::Node& base_root, std::string name,
                    const std::vector<Value>& values, int dim) {
  StudyCase c;
  c.name = std::move(name);
  for (const Value& v : values) c.values.emplace_back(v.key, value_text(v.node));
  YAML::Emitter yaml;
  yaml << apply_values(r, base_root, study.base_scenario, values);
  c.scenario_text = "# case '" + c.name + "' of the study " + study.source + ": " + study.base_scenario +
                    " with " + describe(values) + "\n" + yaml.c_str() + "\n";
  const std::string tag = "case.yaml";
  try {
    c.scenario = parse_scenario_text(c.scenario_text, dim, tag);
  } catch (const ScenarioError& e) {
    const std::string message = without_location(e.what(), tag);
    const Value* culprit = values.empty() ? nullptr : &values.front();
    for (const Value& v : values)
      if (message.find(scenario_key(v.key)) != std::string::npos ||
          (action_key(v.key) && message.find(v.key.substr(0, v.key.find(']') + 1)) != std::string::npos) ||
          (v.key == "max_shear_per_length" && message.find("needle.friction") != std::string::npos))
        culprit = &v;
    if (!culprit) throw;
    r.fail(culprit->node, "case '" + c.name + "' (" + describe(values) + "): " + message);
  }
  if (c.scenario.needle_refinement) {
    std::ostringstream key;
    key.precision(17);
    for (const NeedleSpec& n : c.scenario.needles) {
      for (double x : n.entry) key << x << ' ';
      for (double x : n.direction) key << x << ' ';
      key << n.depth << ';';
    }
    c.mesh_key = key.str();
  }
  return c;
}

std::string grid_point_name(std::size_t index, std::size_t count) {
  const int width = static_cast<int>(std::to_string(count).size());
  char buf[32];
  std::snprintf(buf, sizeof buf, "g%0*zu", width, index + 1);
  return buf;
}

// Every list case (outer) with every grid point (inner; the first grid key varies slowest).
void combine(const Reader& r, Study& study, const YAML::Node& base_root, const std::vector<ListCase>& list,
             const std::vector<GridAxis>& grid, const YAML::Node& root, int dim) {
  std::size_t points = 1;
  for (const GridAxis& a : grid) {
    points *= a.values.size();
    if (points > kMaxCases)
      r.fail(a.values, "the grid has more than " + std::to_string(kMaxCases) + " points");
  }
  const std::size_t n_list = list.empty() ? 1 : list.size();
  if (n_list * points > kMaxCases)
    r.fail(root, "the study has " + std::to_string(n_list * points) + " cases; at most " +
                     std::to_string(kMaxCases));
  for (std::size_t l = 0; l < n_list; ++l)
    for (std::size_t p = 0; p < points; ++p) {
      std::vector<Value> values = list.empty() ? std::vector<Value>{} : list[l].values;
      std::size_t rest = p;
      std::vector<Value> point(grid.size());
      for (std::size_t a = grid.size(); a-- > 0;) {
        point[a] = {grid[a].key, grid[a].values[rest % grid[a].values.size()]};
        rest /= grid[a].values.size();
      }
      values.insert(values.end(), point.begin(), point.end());
      std::string name = list.empty() ? "" : list[l].name;
      if (!grid.empty()) name += (name.empty() ? "" : "-") + grid_point_name(p, points);
      study.cases.push_back(make_case(r, study, base_root, name, values, dim));
    }
}

}  // namespace

Study parse_study_text(const std::string& yaml_text, const std::string& source, int dim) {
  Scenario tag;  // only names the study file in messages
  tag.source = source;
  const Reader r(tag);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ScenarioError(tag.where(e.mark.line >= 0 ? e.mark.line + 1 : 0) + "YAML syntax error: " + e.msg);
  }
  if (!root || root.IsNull()) throw ScenarioError(tag.where(0) + "the study file is empty");
  const Fields top = r.check_keys(root, "", {"scenario", "cases", "grid"});
  Study study;
  study.source = source;
  const YAML::Node& scenario = r.require(top, "scenario", "scenario");
  const std::filesystem::path base = r.string(scenario, "scenario");
  study.base_scenario =
      (base.is_absolute() ? base : std::filesystem::path(source).parent_path() / base).string();
  if (!top["cases"] && !top["grid"]) r.fail(root, "missing key 'cases' or 'grid' (the values to vary)");
  const std::vector<ListCase> list =
      top["cases"] ? parse_cases(r, top["cases"], dim) : std::vector<ListCase>{};
  const std::vector<GridAxis> grid = top["grid"] ? parse_grid(r, top["grid"], dim) : std::vector<GridAxis>{};
  for (const ListCase& c : list)
    for (const Value& v : c.values)
      for (const GridAxis& a : grid)
        if (a.key == v.key)
          r.fail(v.node, "case '" + c.name + "': " + v.key + " is also varied by grid (line " +
                             std::to_string(Reader::line(a.values)) + "); vary each key in one place");
  std::ifstream in(study.base_scenario);
  if (!in) r.fail(scenario, "scenario: cannot open the base scenario " + study.base_scenario);
  study.base = read_scenario(study.base_scenario, dim);
  const YAML::Node base_root = YAML::Load(study.base.text);
  combine(r, study, base_root, list, grid, root, dim);
  for (const auto& k : study_keys()) {
    bool varied = false;
    for (const StudyCase& c : study.cases)
      for (const auto& value : c.values) varied = varied || value.first == k.name;
    if (varied) study.varied.emplace_back(k.name);
  }
  for (const StudyCase& c : study.cases)  // the action keys, in the order they first appear
    for (const auto& value : c.values)
      if (action_key(value.first) &&
          std::find(study.varied.begin(), study.varied.end(), value.first) == study.varied.end())
        study.varied.push_back(value.first);
  return study;
}

Study read_study(const std::string& path, int dim) {
  return parse_study_text(read_input_text(path, "study file"), path, dim);
}

}  // namespace vim::pipeline

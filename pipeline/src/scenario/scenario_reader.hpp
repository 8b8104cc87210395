// Private to scenario.cpp, scenario_labels.cpp and study_reader.cpp: the checked accessors of the scenario
// parser. yaml-cpp gives no position for missing keys or bad conversions, so every access goes through
// Reader, whose failures name the key path, the YAML line and the valid values.
#pragma once

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <string>
#include <vector>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/point_text.hpp>

namespace vim::pipeline {

// The text of a YAML input file (a scenario or a study: `what`); ScenarioError "PATH: cannot open the WHAT"
// if it cannot be read (scenario.cpp).
std::string read_input_text(const std::string& path, const std::string& what);

// `procedure:` (scenario_procedure.cpp): its actions into s.needles (s.procedure, s.needle_list), each
// insertion read by `needle` (the needle keys and stay, seeds) at its key path.
void parse_procedure(const YAML::Node& procedure, Scenario& s,
                     const std::function<NeedleSpec(const YAML::Node&, const std::string&)>& needle);
// `probe:` (scenario_procedure.cpp) into s.probe: its region read by `region`, its support by
// `support` (a condition's `support:` key) at their key paths. Before the procedure.
void parse_probe(
    const YAML::Node& probe, Scenario& s,
    const std::function<RegionSpec(const YAML::Node&, const std::string&)>& region,
    const std::function<void(const YAML::Node&, const std::string&, BoundaryConditionSpec&)>& support);
// `dose:` (scenario_procedure.cpp) into s.dose, its region read by `region` at its key path.
void parse_dose(const YAML::Node& dose, Scenario& s,
                const std::function<RegionSpec(const YAML::Node&, const std::string&)>& region);
// The scenario's `labels:` table into s.labels (scenario_labels.cpp); after the material.
void parse_labels(const YAML::Node& labels, Scenario& s);
// needle.flexible of a needle at `path` (a mapping; the needle's diameter already read into `needle`):
// ScenarioError naming the file, the line and the key for a bad value (scenario_needle_shape.cpp).
void parse_needle_flexible(const Scenario& scenario, const YAML::Node& node, const std::string& path, int dim,
                           NeedleSpec& needle);
// needle.bevel and needle.rotations (either node may be undefined), after flexible and direction.
void parse_needle_bevel(const Scenario& scenario, const YAML::Node& bevel, const YAML::Node& rotations,
                        const std::string& path, NeedleSpec& needle);

namespace {

const char* const kFaceNames[] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};

inline std::string join(const std::vector<std::string>& v, const char* sep = ", ") {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

// Hand-written equivalents of the former std::regex checks (std::regex_match dominated the parse
// time under the fuzzer). ASCII only, like the [A-Za-z0-9] classes they replace.
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
// [+-]?[0-9]+
inline bool is_integer_text(const std::string& t) {
  std::size_t i = (!t.empty() && (t[0] == '+' || t[0] == '-')) ? 1 : 0;
  if (i == t.size()) return false;
  for (; i < t.size(); ++i)
    if (!is_digit(t[i])) return false;
  return true;
}
// [A-Za-z0-9_-]+
inline bool is_folder_name(const std::string& t) {
  if (t.empty()) return false;
  for (char c : t)
    if (!is_alpha(c) && !is_digit(c) && c != '_' && c != '-') return false;
  return true;
}
// [A-Za-z_][A-Za-z0-9_]*
inline bool is_identifier(const std::string& t) {
  if (t.empty() || !(is_alpha(t[0]) || t[0] == '_')) return false;
  for (char c : t)
    if (!is_alpha(c) && !is_digit(c) && c != '_') return false;
  return true;
}

inline std::string scalar_text(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list of " + std::to_string(n.size());
  if (n.IsMap()) return "a mapping";
  return "nothing";
}

// The entries of a mapping, collected once by Reader::check_keys. yaml-cpp's Node::operator[](key)
// decodes and copies every key of the mapping into a std::string (and copies Nodes) on each lookup,
// which dominated the parse time under the fuzzer. Lookup semantics are yaml-cpp's: the first entry
// whose key is a scalar equal to `key`; a missing key gives an undefined node (operator! is true).
class Fields {
 public:
  explicit Fields(const YAML::Node& n) : node_(n) {}
  void add(bool scalar_key, std::string key, const YAML::Node& value) {
    entries_.push_back({scalar_key, std::move(key), value});
  }
  const YAML::Node& node() const { return node_; }
  const YAML::Node& operator[](const char* key) const {
    for (const Entry& e : entries_)
      if (e.scalar_key && e.key == key) return e.value;
    return undefined();
  }

 private:
  struct Entry {
    bool scalar_key;
    std::string key;
    YAML::Node value;
  };
  static const YAML::Node& undefined() {
    static const YAML::Node u(YAML::NodeType::Undefined);
    return u;
  }
  YAML::Node node_;
  std::vector<Entry> entries_;
};

class Reader {
 public:
  explicit Reader(const Scenario& s) : s_(s) {}
  const Scenario& scenario() const { return s_; }

  [[noreturn]] void fail(const YAML::Node& n, const std::string& msg) const {
    throw ScenarioError(s_.where(line(n)) + msg);
  }
  static int line(const YAML::Node& n) {
    if (!n.IsDefined()) return 0;
    const auto m = n.Mark();
    return m.line >= 0 ? m.line + 1 : 0;
  }

  void expect_map(const YAML::Node& n, const std::string& path) const {
    if (!n.IsMap()) fail(n, path + " must be a mapping, got " + scalar_text(n));
  }
  // Checks that n is a mapping with only valid keys and returns its entries for the lookups.
  Fields check_keys(const YAML::Node& n, const std::string& path,
                    const std::vector<std::string>& valid) const {
    expect_map(n, path);
    Fields fields(n);
    std::vector<std::pair<std::string, int>> seen;  // key, line
    for (const auto& kv : n) {
      std::string k = kv.first.Scalar();
      // yaml-cpp keeps both entries of a repeated key and looks up the first: refuse it instead of
      // silently ignoring the later value.
      for (const auto& [key, at] : seen)
        if (key == k)
          fail(kv.first, "duplicate key '" + (path.empty() ? k : path + "." + k) + "' (first given on line " +
                             std::to_string(at) + "); give each key once");
      seen.emplace_back(k, line(kv.first));
      if (std::find(valid.begin(), valid.end(), k) == valid.end())
        fail(kv.first, "unknown key '" + (path.empty() ? k : path + "." + k) + "'; valid keys" +
                           (path.empty() ? "" : " of " + path) + ": " + join(valid));
      fields.add(kv.first.IsScalar(), std::move(k), kv.second);
    }
    return fields;
  }
  const YAML::Node& require(const Fields& parent, const char* key, const std::string& path) const {
    const YAML::Node& n = parent[key];
    if (!n) fail(parent.node(), "missing key '" + path + "'");
    return n;
  }

  double number(const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) fail(n, path + " must be a number, got " + scalar_text(n));
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, path + " must be a number, got " + scalar_text(n));
    }
    if (!std::isfinite(v)) fail(n, path + " must be a finite number, got " + scalar_text(n));
    return v;
  }
  double positive(const YAML::Node& n, const std::string& path) const {
    const double v = number(n, path);
    if (!(v > 0.0)) fail(n, path + " must be > 0, got " + number_text(v));
    return v;
  }
  long integer(const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) fail(n, path + " must be an integer, got " + scalar_text(n));
    if (!is_integer_text(n.Scalar())) fail(n, path + " must be an integer, got " + scalar_text(n));
    try {
      return n.as<long>();
    } catch (const YAML::Exception&) {
      fail(n, path + " must be an integer, got " + scalar_text(n));
    }
  }
  std::string string(const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) fail(n, path + " must be a string, got " + scalar_text(n));
    return n.Scalar();
  }
  std::string choice(const YAML::Node& n, const std::string& path,
                     const std::vector<std::string>& valid) const {
    const std::string v = string(n, path);
    if (std::find(valid.begin(), valid.end(), v) == valid.end())
      fail(n, path + " = '" + v + "' is not valid; use one of: " + join(valid));
    return v;
  }
  bool boolean(const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) fail(n, path + " must be true or false, got " + scalar_text(n));
    try {
      return n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(n, path + " must be true or false, got " + scalar_text(n));
    }
  }
  std::vector<double> vector(const YAML::Node& n, const std::string& path, int dim) const {
    if (!n.IsSequence() || static_cast<int>(n.size()) != dim)
      fail(n, path + " must be a list of " + std::to_string(dim) + " numbers ([" +
                  (dim == 3 ? "x, y, z" : "x, y") + "]) for a " + std::to_string(dim) + "D image, got " +
                  scalar_text(n));
    std::vector<double> v;
    for (std::size_t i = 0; i < n.size(); ++i)
      v.push_back(number(n[i], path + "[" + std::to_string(i) + "]"));
    return v;
  }
  std::vector<double> nonzero_vector(const YAML::Node& n, const std::string& path, int dim) const {
    std::vector<double> v = vector(n, path, dim);
    // Scaled by the largest component first, so that neither [1e200, 0, 0] (whose squared norm
    // overflows) nor [1e-170, 0, 0] (which underflows) loses its direction.
    double big = 0.0;
    for (double x : v) big = std::max(big, std::abs(x));
    if (!(big > 0.0)) fail(n, path + " must be a non-zero vector, got [" + join_numbers(v) + "]");
    double s = 0.0;
    for (double& x : v) {
      x /= big;
      s += x * x;
    }
    for (double& x : v) x /= std::sqrt(s);
    return v;
  }
  static std::string join_numbers(const std::vector<double>& v) {
    std::vector<std::string> s;
    for (double x : v) s.push_back(number_text(x));
    return join(s);
  }

 private:
  const Scenario& s_;
};

}  // namespace

}  // namespace vim::pipeline

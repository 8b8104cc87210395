// The outcomes of a study's cases and study.csv (study_table.hpp).
#include "study/study_table.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <vim/pipeline/common/atomic_file.hpp>

namespace vim::pipeline {

using nlohmann::json;

json final_results(const json& report) {
  json needles = json::array();
  for (const json& n : report.at("simulation").at("needles")) {
    const json& f = n.at("final");
    json targets = json::object();
    for (const auto& [name, t] : f.at("targets").items()) targets[name] = t.at("displacement");
    needles.push_back({{"name", n.at("name")},
                       {"axial_force", f.at("axial_force")},
                       {"lateral_force", f.at("lateral_force")},
                       {"targets", targets}});
  }
  return needles;
}

namespace {

// study.csv's procedure columns of a base scenario: the seed error with seeds, the dose with `dose:`.
std::vector<std::string> procedure_columns(const Scenario& sc) {
  std::vector<std::string> columns;
  const bool seeds =
      std::any_of(sc.needles.begin(), sc.needles.end(), [](const NeedleSpec& n) { return !n.seeds.empty(); });
  if (sc.procedure && seeds) columns = {"seed_error_mean", "seed_error_rms", "seed_error_max"};
  if (sc.dose)
    for (const char* c : {"d90_planned", "d90_final", "v100_planned", "v100_final"}) columns.push_back(c);
  return columns;
}

}  // namespace

json procedure_results(const json& report) {
  json r = json::object();
  const json& sim = report.at("simulation");
  if (sim.contains("seeds")) {
    const json& all = sim.at("seeds").at("all");
    r["seed_error_mean"] = all.at("mean_error");
    r["seed_error_rms"] = all.at("rms_error");
    r["seed_error_max"] = all.at("max_error");
  }
  if (sim.contains("dose")) {
    const json& d = sim.at("dose");
    for (const char* when : {"planned", "final"}) {
      r[std::string("d90_") + when] = d.at(when).at("d90_gy");
      r[std::string("v100_") + when] = d.at(when).at("v100_percent");
    }
  }
  return r;
}

namespace {

// The shortest text that reads back as the same double (JSON's number format).
std::string number(double x) { return json(x).dump(); }

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

const char* const kAxes[] = {"_x", "_y", "_z"};

// An action key's value in a case's scenario as written there: per axis for entry, direction and
// translate, the depths separated by spaces for seeds; empty where the action does not give it.
std::vector<std::string> action_values(const Study& study, const StudyCase& c, const ActionKey& a) {
  const bool vector = a.key == "entry" || a.key == "direction" || a.key == "translate";
  std::vector<std::string> out(vector ? static_cast<std::size_t>(study.base.dim) : 1);
  const YAML::Node root = YAML::Load(c.scenario_text);
  const YAML::Node& procedure = static_cast<const YAML::Node&>(root)["procedure"];
  if (!procedure || !procedure.IsSequence() || a.index >= procedure.size()) return out;
  const YAML::Node action = procedure[a.index];
  if (!action.IsMap() || action.size() != 1) return out;
  const YAML::Node& v = static_cast<const YAML::Node&>(action.begin()->second)[a.key];
  if (!v) return out;
  if (v.IsScalar()) out[0] = v.Scalar();
  for (std::size_t i = 0; v.IsSequence() && i < v.size(); ++i) {
    if (vector && i < out.size()) out[i] = v[i].Scalar();
    if (!vector) out[0] += (i ? " " : "") + v[i].Scalar();
  }
  return out;
}

// The columns of the varied inputs and the case's values for them.
void input_columns(const Study& study, std::vector<std::string>& header) {
  for (const std::string& key : study.varied) {
    const std::optional<ActionKey> a = action_key(key);
    if (key == "entry" || key == "direction" ||
        (a && (a->key == "entry" || a->key == "direction" || a->key == "translate")))
      for (int a = 0; a < study.base.dim; ++a) header.push_back(key + kAxes[a]);
    else
      header.push_back(key);
  }
}

void input_values(const Study& study, const StudyCase& c, std::vector<std::string>& row) {
  const Scenario& sc = c.scenario;
  const NeedleSpec* needle = sc.needles.empty() ? nullptr : &sc.needles.front();
  for (const std::string& key : study.varied) {
    if (const std::optional<ActionKey> a = action_key(key)) {
      for (std::string& v : action_values(study, c, *a)) row.push_back(std::move(v));
    } else if (key == "entry" || key == "direction") {
      for (int a = 0; a < study.base.dim; ++a)
        row.push_back(needle ? number((key == "entry" ? needle->entry : needle->direction)[a]) : "");
    } else if (key == "depth") {
      row.push_back(needle ? number(needle->depth) : "");
    } else if (key == "scale") {
      row.push_back(number(sc.scale));
    } else if (key == "poisson_ratio") {
      row.push_back(number(sc.poisson_ratio));
    } else {  // max_shear_per_length
      const bool slips = needle && needle->friction == NeedleSpec::Friction::stick_slip;
      row.push_back(slips ? number(needle->max_shear_per_length) : "");
    }
  }
}

// Per needle of the base scenario: forces and target displacements (prefixed by the needle's name
// when the scenario has several needles).
void result_columns(const Study& study, std::vector<std::string>& header) {
  for (const NeedleSpec& n : study.base.needles) {
    const std::string p = study.base.needles.size() > 1 ? n.name + "_" : "";
    header.push_back(p + "axial_force");
    header.push_back(p + "lateral_force");
    for (const TargetSpec& t : study.base.targets)
      for (int a = 0; a < study.base.dim; ++a) header.push_back(p + t.name + kAxes[a]);
  }
}

void result_values(const Study& study, const CaseOutcome& o, std::vector<std::string>& row) {
  for (std::size_t k = 0; k < study.base.needles.size(); ++k) {
    const bool have = o.status == "done" && k < o.needles.size();
    row.push_back(have ? number(o.needles[k].at("axial_force").get<double>()) : "");
    row.push_back(have ? number(o.needles[k].at("lateral_force").get<double>()) : "");
    for (const TargetSpec& t : study.base.targets)
      for (int a = 0; a < study.base.dim; ++a)
        row.push_back(have ? number(o.needles[k].at("targets").at(t.name).at(a).get<double>()) : "");
  }
}

}  // namespace

void write_study_csv(const std::filesystem::path& path, const Study& study,
                     const std::vector<CaseOutcome>& outcomes) {
  std::vector<std::string> header = {"case", "status"};
  input_columns(study, header);
  result_columns(study, header);
  for (const std::string& c : procedure_columns(study.base)) header.push_back(c);
  header.push_back("message");
  write_text_atomically(path, [&](std::ostream& s) {
    for (std::size_t i = 0; i < header.size(); ++i) s << (i ? "," : "") << header[i];
    s << "\n";
    for (const CaseOutcome& o : outcomes) {
      std::vector<std::string> row = {study.cases[o.index].name, o.status};
      input_values(study, study.cases[o.index], row);
      result_values(study, o, row);
      for (const std::string& c : procedure_columns(study.base))
        row.push_back(o.status == "done" && o.procedure.contains(c) ? number(o.procedure.at(c).get<double>())
                                                                    : "");
      row.push_back(o.message.empty() ? "" : quoted(o.message));
      for (std::size_t i = 0; i < row.size(); ++i) s << (i ? "," : "") << row[i];
      s << "\n";
    }
  });
}

}  // namespace vim::pipeline

// The scenario's `labels:` table (docs/labels.md): for a label image (--labels), each label's name and
// Young's modulus, `{1: {name: gland, youngs_modulus: 30 | image, poisson_ratio: 0.49, model: linear}}`.
// The FEM takes one Poisson ratio and one material model: a label's poisson_ratio and model must equal
// the material's.
#include <cmath>
#include <vim/pipeline/scenario/scenario.hpp>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

void parse_labels(const YAML::Node& labels, Scenario& s) {
  const Reader r(s);
  r.expect_map(labels, "labels");
  for (const auto& kv : labels) {
    const std::string key = kv.first.Scalar();
    if (!kv.first.IsScalar() || !is_integer_text(key) || key.size() > 9)
      r.fail(kv.first, "labels: the key " + scalar_text(kv.first) +
                           " is not a label; the keys are the label "
                           "image's integer labels, e.g. labels: {1: {name: gland, youngs_modulus: 30}}");
    LabelSpec spec;
    spec.label = std::stoi(key);
    spec.line = Reader::line(kv.first);
    for (const LabelSpec& other : s.labels)
      if (other.label == spec.label)
        r.fail(kv.first,
               "labels: label " + key + " is given twice (first on line " + std::to_string(other.line) + ")");
    const std::string path = "labels." + key;
    const Fields f = r.check_keys(kv.second, path, {"name", "youngs_modulus", "poisson_ratio", "model"});
    spec.name = f["name"] ? r.string(f["name"], path + ".name") : "label_" + key;
    if (!is_identifier(spec.name))
      r.fail(f["name"],
             path + ".name must be a name of letters, digits and '_' (not starting with a digit), got '" +
                 spec.name + "'");
    for (const LabelSpec& other : s.labels)
      if (other.name == spec.name)
        r.fail(f["name"], path + ".name '" + spec.name + "' is also the name of label " +
                              std::to_string(other.label) + "; give each label its own name");
    if (const YAML::Node& e = f["youngs_modulus"]) {
      if (!(e.IsScalar() && e.Scalar() == "image")) {
        double v = 0.0;
        try {
          v = e.as<double>();
        } catch (const YAML::Exception&) {
          r.fail(e, path + ".youngs_modulus must be 'image' or a number > 0, got " + scalar_text(e));
        }
        if (!(v > 0.0) || !std::isfinite(v))
          r.fail(e, path + ".youngs_modulus must be 'image' or a number > 0, got " + scalar_text(e));
        spec.youngs_modulus = v;
      }
    }
    if (const YAML::Node& nu = f["poisson_ratio"]) {
      const double v = r.number(nu, path + ".poisson_ratio");
      if (v != s.poisson_ratio)
        r.fail(nu, path + ".poisson_ratio = " + scalar_text(nu) + " differs from material.poisson_ratio (" +
                       std::to_string(s.poisson_ratio) +
                       "): the model takes one Poisson ratio; give it as material.poisson_ratio");
    }
    if (const YAML::Node& m = f["model"]) {
      const bool neo = r.choice(m, path + ".model", {"linear", "neo-hookean"}) == "neo-hookean";
      if (neo != (s.material_model == Scenario::MaterialModel::neo_hookean))
        r.fail(m, path +
                      ".model differs from material.model: the model takes one material model; give it as "
                      "material.model");
    }
    s.labels.push_back(spec);
  }
}

}  // namespace vim::pipeline

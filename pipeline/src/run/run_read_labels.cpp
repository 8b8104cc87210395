// PipelineRun, stage 1 (pipeline_run.hpp), the label image (--labels, docs/labels.md): read and checked
// (integers), resampled nearest-neighbour into IMAGE's grid or, alone, turned into the modulus image
// of the label table (the scenario's `labels:`, then --label-modulus); every scenario label must be in
// the image, and alone every label needs a modulus. The voxel model takes the labels beside IMAGE for
// regions and targets alone (its moduli are IMAGE's).
#include <map>
#include <sstream>
#include <vim/label_statistics.hpp>
#include <vim/pipeline/image/label_image.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>

#include "run/run_support.hpp"

namespace vim::pipeline {

namespace {

std::string list_text(const std::vector<int>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s;
}

// --label-modulus LABEL=E
std::pair<int, double> label_modulus_option(const std::string& text) {
  const auto eq = text.find('=');
  std::size_t used_l = 0, used_e = 0;
  int label = 0;
  double e = 0.0;
  bool ok = eq != std::string::npos;
  try {
    if (ok) {
      label = std::stoi(text.substr(0, eq), &used_l);
      e = std::stod(text.substr(eq + 1), &used_e);
    }
  } catch (const std::exception&) {
    ok = false;
  }
  ok = ok && used_l == eq && used_e == text.size() - eq - 1 && e > 0.0 && std::isfinite(e);
  if (!ok)
    throw InputError("--label-modulus " + text +
                     ": expected LABEL=E with an integer label and a Young's "
                     "modulus > 0, e.g. --label-modulus 2=30");
  return {label, e};
}

// The voxel model takes labels beside IMAGE, for label regions and targets only: its moduli are IMAGE's.
void check_voxel_labels(const RunOptions& o, const std::map<int, double>& label_modulus) {
  if (o.mesher != MesherKind::voxel) return;
  if (o.labels_alone())
    throw InputError("--labels " + o.labels +
                     ": the voxel model (--mesher voxel) takes its moduli from IMAGE alone; give IMAGE "
                     "beside the labels, or mesh the labels with --mesher vim or --mesher grid");
  if (!label_modulus.empty())
    throw InputError(
        "--labels " + o.labels + ": label " + std::to_string(label_modulus.begin()->first) +
        " has a Young's modulus of its own, but the voxel model (--mesher voxel) takes its moduli "
        "from IMAGE alone (its labels serve regions and targets): give the label youngs_modulus: "
        "image, or use --mesher vim or --mesher grid");
}

// Every label region of the scenario (boundary conditions, needle tissues, the dose region), with its
// YAML line.
std::vector<std::pair<RegionSpec*, int>> label_regions(Scenario& sc) {
  std::vector<std::pair<RegionSpec*, int>> out;
  if (sc.dose && sc.dose->region.kind == RegionSpec::Kind::label)
    out.emplace_back(&sc.dose->region, sc.dose->line);
  for (BoundaryConditionSpec& bc : sc.boundary_conditions)
    if (bc.region.kind == RegionSpec::Kind::label) out.emplace_back(&bc.region, bc.line);
  for (NeedleSpec& n : sc.needles)
    for (TissueSpec& t : n.tissues)
      if (t.region && t.region->kind == RegionSpec::Kind::label) out.emplace_back(&*t.region, t.line);
  return out;
}

// The centroid (frame) of the voxel centres of `label` in `labels` (the label is present).
template <int dim>
Eigen::Matrix<double, dim, 1> label_centroid(const Image<dim>& labels, int label) {
  Eigen::Matrix<double, dim, 1> sum = Eigen::Matrix<double, dim, 1>::Zero();
  double n = 0.0;
  for (std::size_t v = 0; v < labels.voxel_count(); ++v)
    if (static_cast<int>(labels.data[v]) == label) {
      sum += labels.point_of(labels.index_of(v));
      n += 1.0;
    }
  return sum / n;
}

// The label image file beside IMAGE, of IMAGE's dimension.
template <int dim>
OrientedImage<dim> label_file(const std::string& path) {
  const ImageFile file(path);
  if (file.dimension() != dim)
    throw InputError(path + ": the label image is " + std::to_string(file.dimension()) + "D but IMAGE is " +
                     std::to_string(dim) + "D; they must match");
  return file.read<dim>();
}

}  // namespace

template <int dim>
void PipelineRun<dim>::read_label_image() {
  const RunOptions& o = options_;
  if (o.labels.empty() && scenario_)
    if (const auto regions = label_regions(*scenario_); !regions.empty())
      throw ScenarioError(scenario_->where(regions.front().second) + "region {label: " +
                          regions.front().first->label + "} needs a label image (--labels LABELS)");
  if (o.labels.empty() && scenario_)
    for (const TargetSpec& t : scenario_->targets)
      if (!t.label.empty())
        throw ScenarioError(scenario_->where(t.line) + "target '" + t.name + "' {label: " + t.label +
                            "} needs a label image (--labels LABELS)");
  if (o.labels.empty()) {
    if (scenario_ && !scenario_->labels.empty())
      throw ScenarioError(scenario_->where(scenario_->labels.front().line) +
                          "labels: the label table needs a label image (--labels LABELS)");
    if (!o.label_moduli.empty()) throw InputError("--label-modulus needs a label image (--labels LABELS)");
    return;
  }
  if (o.labels_alone()) {
    labels_ = image_->image;
  } else {
    const OrientedImage<dim> read =
        inputs_ && inputs_->labels ? std::move(*inputs_->labels) : label_file<dim>(o.labels);
    check_label_image(read.image, o.labels);
    labels_ = labels_in_grid_of<dim>(*image_, read, o.labels);
  }
  check_label_image(*labels_, o.labels);
  const std::vector<int> present = labels_present(*labels_);
  if (present.size() > LabelStatistics<dim>::kMaxLabels)
    throw InputError(o.labels + ": " + std::to_string(present.size()) + " distinct labels; at most " +
                     std::to_string(LabelStatistics<dim>::kMaxLabels) + " are supported");
  const auto is_present = [&](int l) {
    return std::find(present.begin(), present.end(), l) != present.end();
  };
  for (int l : present) model_.label_name[l] = "label_" + std::to_string(l);
  if (scenario_)
    for (const LabelSpec& spec : scenario_->labels) {
      if (!is_present(spec.label))
        throw ScenarioError(scenario_->where(spec.line) + "labels: label " + std::to_string(spec.label) +
                            " (" + spec.name + ") is not in " + o.labels + ", which holds the labels " +
                            list_text(present));
      model_.label_name[spec.label] = spec.name;
      if (spec.youngs_modulus) model_.label_modulus[spec.label] = *spec.youngs_modulus;
    }
  for (const std::string& text : o.label_moduli) {
    const auto [label, e] = label_modulus_option(text);
    if (!is_present(label))
      throw InputError("--label-modulus " + text + ": label " + std::to_string(label) + " is not in " +
                       o.labels + ", which holds the labels " + list_text(present));
    model_.label_modulus[label] = e;
  }
  check_voxel_labels(o, model_.label_modulus);
  if (o.labels_alone()) {
    for (int l : present)
      if (!model_.label_modulus.count(l))
        throw InputError(o.labels + ": label " + std::to_string(l) + " (" + model_.label_name[l] +
                         ") has no Young's modulus: give --label-modulus " + std::to_string(l) +
                         "=E or labels: {" + std::to_string(l) +
                         ": {youngs_modulus: E}} in the scenario (a label image alone has no modulus image)");
    if (scenario_ && (scenario_->scale != 1.0 || scenario_->clamp))
      throw ScenarioError(scenario_->where(0) +
                          "material.scale and material.clamp convert a modulus image's values; with --labels "
                          "alone the label table gives the moduli: remove them");
    // The modulus image of the label table: the element means of meshes without the majority rule (and
    // the image statistics of report.json) read it.
    for (float& v : image_->image.data) v = static_cast<float>(model_.label_modulus.at(static_cast<int>(v)));
  }
  // Label regions and targets: a label's name or number, resolved once; the simulation and the decks
  // test points against the label image; a label target is the centroid of the label's voxels.
  const auto label_of = [&](const std::string& text, int line, const std::string& what) {
    for (const auto& [label, name] : model_.label_name)
      if (text == name || text == std::to_string(label)) return label;
    std::string names;
    for (const auto& [label, name] : model_.label_name)
      names += (names.empty() ? "" : ", ") + std::to_string(label) + " (" + name + ")";
    throw ScenarioError(scenario_->where(line) + what + " {label: " + text + "}: no label of " + o.labels +
                        " has this name or number; its labels are " + names);
  };
  if (scenario_) {
    for (auto& [region, line] : label_regions(*scenario_))
      region->label_value = label_of(region->label, line, "region");
    for (TargetSpec& t : scenario_->targets)
      if (!t.label.empty()) {
        const Eigen::Matrix<double, dim, 1> c =
            image_->to_world(label_centroid(*labels_, label_of(t.label, t.line, "target '" + t.name + "'")));
        t.position.assign(c.data(), c.data() + dim);
      }
  }
  model_.label_image = std::make_shared<const Image<dim>>(*labels_);
  inputs_result_.labels =
      nlohmann::json{{"file", o.labels}, {"alone", o.labels_alone()}, {"labels", present}};
}

template void PipelineRun<2>::read_label_image();
template void PipelineRun<3>::read_label_image();

}  // namespace vim::pipeline

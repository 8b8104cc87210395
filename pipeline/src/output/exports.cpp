// Export dispatcher (exports.hpp): the --export list parsed, material bins shared by every format, the
// world mesh, and write_exports running the export table's writers (export_registry.hpp) and filling
// report["exports"].
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/output/exports.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

std::vector<std::string> parse_export_formats(const std::string& comma_separated) {
  std::vector<std::string> out;
  std::stringstream in(comma_separated);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) continue;
    if (item == "all") return export_formats();
    export_format(item);  // throws for an unknown name
    if (std::find(out.begin(), out.end(), item) == out.end()) out.push_back(item);
  }
  if (out.empty()) return export_formats();
  return out;
}

namespace {

// One bin per label of the elements (ascending), each element's modulus kept.
template <int dim>
MaterialBins label_bins(const MeshModel<dim>& model, std::vector<double> element_modulus) {
  MaterialBins bins;
  bins.by_label = true;
  bins.element_modulus = std::move(element_modulus);
  std::vector<int> labels(model.label.begin(), model.label.end());
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  const std::size_t n = labels.size();
  bins.modulus.assign(n, 0.0);
  bins.lower.assign(n, INFINITY);
  bins.upper.assign(n, -INFINITY);
  bins.count.assign(n, 0);
  bins.element_material.resize(model.label.size());
  for (std::size_t c = 0; c < model.label.size(); ++c) {
    const std::size_t k = static_cast<std::size_t>(
        std::lower_bound(labels.begin(), labels.end(), model.label[c]) - labels.begin());
    bins.element_material[c] = static_cast<int>(k) + 1;
    const double e = bins.element_modulus[c];
    bins.modulus[k] += e;
    bins.lower[k] = std::min(bins.lower[k], e);
    bins.upper[k] = std::max(bins.upper[k], e);
    ++bins.count[k];
  }
  for (std::size_t k = 0; k < n; ++k) {
    bins.modulus[k] /= static_cast<double>(bins.count[k]);
    bins.material_id.push_back(labels[k]);
    const auto it = model.label_name.find(labels[k]);
    bins.name.push_back(it != model.label_name.end() ? it->second : "label_" + std::to_string(labels[k]));
  }
  return bins;
}

}  // namespace

template <int dim>
MaterialBins material_bins(const MeshModel<dim>& model, int max_bins) {
  if (max_bins < 1) throw std::invalid_argument("max_material_bins must be at least 1");
  const std::size_t m = model.mesh.n_cells();
  MaterialBins bins;
  bins.element_modulus.resize(m);
  const bool have_modulus = model.youngs_modulus.size() == m && m > 0;
  if (!have_modulus && model.values.size() != m)
    throw std::invalid_argument(
        "model has neither a per-element modulus nor per-element values for every cell");
  for (std::size_t c = 0; c < m; ++c) {
    const double e = have_modulus ? model.youngs_modulus[c] : model.values[c].mean;
    if (!std::isfinite(e))
      throw std::invalid_argument("element " + std::to_string(c) + " has a non-finite modulus");
    bins.element_modulus[c] = e;
  }
  if (m == 0) return bins;

  std::vector<double> distinct = bins.element_modulus;
  std::sort(distinct.begin(), distinct.end());
  // Values that differ by round-off only (1.1999999999999997 and 1.2: element means of the same
  // material summed in another order) are one material: a group runs while each value is within
  // 1e-12 (relative) of the group's smallest, which represents it.
  distinct.erase(
      std::unique(distinct.begin(), distinct.end(),
                  [](double a, double b) { return b - a <= 1e-12 * std::max(std::abs(a), std::abs(b)); }),
      distinct.end());
  std::vector<int> raw(m);  // 0-based bin before dropping empty ones
  int n_raw = 0;
  if (distinct.size() <= static_cast<std::size_t>(max_bins)) {
    n_raw = static_cast<int>(distinct.size());
    for (std::size_t c = 0; c < m; ++c)  // the group whose smallest value is the largest <= e
      raw[c] = static_cast<int>(std::upper_bound(distinct.begin(), distinct.end(), bins.element_modulus[c]) -
                                distinct.begin()) -
               1;
  } else {
    n_raw = max_bins;
    const double lo = distinct.front(), hi = distinct.back();
    for (std::size_t c = 0; c < m; ++c) {
      const double t = (bins.element_modulus[c] - lo) / (hi - lo) * n_raw;
      raw[c] = std::clamp(static_cast<int>(std::floor(t)), 0, n_raw - 1);
    }
  }
  std::vector<long> count(n_raw, 0);
  for (int b : raw) ++count[b];
  std::vector<int> id(n_raw, 0);
  int next = 0;
  for (int b = 0; b < n_raw; ++b)
    if (count[b] > 0) id[b] = ++next;
  bins.modulus.assign(next, 0.0);
  bins.lower.assign(next, INFINITY);
  bins.upper.assign(next, -INFINITY);
  bins.count.assign(next, 0);
  bins.element_material.resize(m);
  for (std::size_t c = 0; c < m; ++c) {
    const int k = id[raw[c]];
    bins.element_material[c] = k;
    const double e = bins.element_modulus[c];
    bins.modulus[k - 1] += e;
    bins.lower[k - 1] = std::min(bins.lower[k - 1], e);
    bins.upper[k - 1] = std::max(bins.upper[k - 1], e);
    ++bins.count[k - 1];
  }
  for (int k = 0; k < next; ++k) bins.modulus[k] /= static_cast<double>(bins.count[k]);
  for (int k = 0; k < next; ++k) {
    bins.material_id.push_back(k + 1);
    bins.name.push_back("material_" + std::to_string(k + 1));
  }
  if (model.label.size() == m) return label_bins(model, std::move(bins.element_modulus));
  return bins;
}

template <int dim>
SimplexMesh<dim> world_mesh(const MeshModel<dim>& model) {
  SimplexMesh<dim> w;
  w.points.reserve(model.mesh.n_points());
  for (const auto& p : model.mesh.points) w.points.push_back(model.transform.to_world(p));
  w.cells = model.mesh.cells;
  orient_positively(w);  // a mirroring direction matrix (det < 0) flips every cell
  return w;
}

template <int dim>
nlohmann::json write_exports(const ExportInput<dim>& input, const fs::path& dir,
                             const std::vector<std::string>& formats) {
  const MeshModel<dim>& model = input.model;
  const ExportOptions& options = input.options;
  for (const auto& f : formats) export_format(f);  // an unknown name throws before anything is written
  if (!(options.poisson_ratio > -1.0 && options.poisson_ratio < 0.5))
    throw std::invalid_argument("poisson_ratio must be in (-1, 0.5), got " +
                                std::to_string(options.poisson_ratio));
  if (options.max_material_bins < 1 || options.max_material_bins > 255)
    throw std::invalid_argument("max_material_bins must be in [1, 255]");
  if (options.degree < 1 || options.degree > 2) throw std::invalid_argument("export degree must be 1 or 2");
  const MaterialBins bins = material_bins(model, options.max_material_bins);
  const SimplexMesh<dim>& world = input.world;
  const SolverDeck<dim> deck = solver_deck(model, world, bins.element_modulus, options.poisson_ratio,
                                           options.degree, options.scenario);
  fs::create_directories(dir);

  nlohmann::json out;
  out["coordinates"] = "world (origin + direction·(frame point − origin), the input image's physical space)";
  out["modulus_source"] = model.youngs_modulus.size() == model.mesh.n_cells() && model.mesh.n_cells() > 0
                              ? "youngs_modulus"
                              : "element mean";
  out["poisson_ratio"] = options.poisson_ratio;
  out["degree"] = options.degree;
  out["conditions"] = options.scenario != nullptr;
  out["not_expressed"] = deck.not_expressed;
  nlohmann::json table = nlohmann::json::array();
  for (std::size_t k = 0; k < bins.n_bins(); ++k) {
    table.push_back({{"id", k + 1},
                     {"E", bins.modulus[k]},
                     {"E_min", bins.lower[k]},
                     {"E_max", bins.upper[k]},
                     {"elements", bins.count[k]}});
    if (bins.by_label) table.back()["label"] = bins.material_id[k], table.back()["name"] = bins.name[k];
  }
  out["material_table"] = table;
  out["element_modulus"] = bins.element_modulus;
  out["files"] = nlohmann::json::object();
  const auto nonpositive = std::count_if(bins.element_modulus.begin(), bins.element_modulus.end(),
                                         [](double e) { return !(e > 0.0); });
  if (nonpositive > 0 && !options.scenario)
    out["warnings"].push_back(
        std::to_string(nonpositive) + " of " + std::to_string(bins.element_modulus.size()) +
        " elements have a modulus <= 0 (their image mean): mesh.inp and mesh.feb cannot be "
        "solved as they are. Use --simulate with a scenario whose material.scale maps the image "
        "to a modulus and material.clamp: [min, max] lifts values <= 0");

  const ExportData<dim> data{world, bins, deck};
  for (const ExportFormat& row : export_table()) {
    if (std::find(formats.begin(), formats.end(), row.name) == formats.end()) continue;
    const ExportWriter<dim> write = row.writer<dim>();
    if (!write) {
      out["skipped"][row.name] = row.skipped_why;
      continue;
    }
    const fs::path path = dir / ("mesh." + row.name);
    write(path, data);
    out["files"][row.name] = path.string();
  }
  return out;
}

template <int dim>
nlohmann::json write_exports(const MeshModel<dim>& model, const fs::path& dir,
                             const std::vector<std::string>& formats, const ExportOptions& options) {
  const SimplexMesh<dim> world = world_mesh(model);
  return write_exports<dim>(ExportInput<dim>{model, world, options}, dir, formats);
}

template nlohmann::json write_exports<2>(const ExportInput<2>&, const fs::path&,
                                         const std::vector<std::string>&);
template nlohmann::json write_exports<3>(const ExportInput<3>&, const fs::path&,
                                         const std::vector<std::string>&);
template MaterialBins material_bins<2>(const MeshModel<2>&, int);
template MaterialBins material_bins<3>(const MeshModel<3>&, int);
template SimplexMesh<2> world_mesh<2>(const MeshModel<2>&);
template SimplexMesh<3> world_mesh<3>(const MeshModel<3>&);
template nlohmann::json write_exports<2>(const MeshModel<2>&, const fs::path&,
                                         const std::vector<std::string>&, const ExportOptions&);
template nlohmann::json write_exports<3>(const MeshModel<3>&, const fs::path&,
                                         const std::vector<std::string>&, const ExportOptions&);

}  // namespace vim::pipeline

// report.json pieces and the text summary (see report.hpp).
#include <cmath>
#include <cstdio>
#include <limits>
#include <vim/pipeline/output/report.hpp>
#include <vim/quality.hpp>

namespace vim::pipeline {

using nlohmann::json;

template <int dim>
ImageSummary summarize(const Image<dim>& image) {
  ImageSummary s;
  s.voxels = image.data.size();
  if (s.voxels == 0) return s;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
  for (float v : image.data) {
    lo = std::min(lo, static_cast<double>(v));
    hi = std::max(hi, static_cast<double>(v));
    sum += v;
  }
  s.min = lo;
  s.max = hi;
  s.mean = sum / static_cast<double>(s.voxels);
  double q = 0.0;
  for (float v : image.data) q += (v - s.mean) * (v - s.mean);
  s.stddev = std::sqrt(q / static_cast<double>(s.voxels));
  return s;
}

template <int dim>
json image_json(const OrientedImage<dim>& image, const std::string& file) {
  json j;
  j["file"] = file;
  j["dimension"] = dim;
  j["size"] = image.image.size;
  j["spacing"] = image.image.spacing;
  j["origin"] = image.image.origin;
  json d = json::array();
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) d.push_back(image.direction(a, b));
  j["direction"] = d;
  // World bounding box of the voxel box (all 2^dim corners mapped through the direction).
  using P = Eigen::Matrix<double, dim, 1>;
  P lo = P::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  const P bmin = image.image.box_min(), bmax = image.image.box_max();
  for (int corner = 0; corner < (1 << dim); ++corner) {
    P p;
    for (int a = 0; a < dim; ++a) p[a] = (corner >> a) & 1 ? bmax[a] : bmin[a];
    const P w = image.to_world(p);
    lo = lo.cwiseMin(w);
    hi = hi.cwiseMax(w);
  }
  std::vector<double> extent(dim);
  for (int a = 0; a < dim; ++a) extent[a] = bmax[a] - bmin[a];
  j["extent"] = extent;
  j["world_bounds"] = {{"min", std::vector<double>(lo.data(), lo.data() + dim)},
                       {"max", std::vector<double>(hi.data(), hi.data() + dim)}};
  // The voxel box's centre in world coordinates (for an oblique image not the bounds' midpoint).
  const P centre = image.to_world(0.5 * (bmin + bmax));
  j["world_centre"] = std::vector<double>(centre.data(), centre.data() + dim);
  const ImageSummary s = summarize(image.image);
  j["voxels"] = s.voxels;
  j["values"] = {{"min", s.min}, {"max", s.max}, {"mean", s.mean}, {"stddev", s.stddev}};
  return j;
}

json quality_json(const MeshQuality& q) {
  return {{"min_dihedral_deg", q.min_dihedral_deg},
          {"max_dihedral_deg", q.max_dihedral_deg},
          {"min_nrr", q.min_nrr},
          {"inverted", q.inverted}};
}

json history_json(const std::vector<IterationRecord>& history) {
  json h = json::array();
  for (const auto& r : history)
    h.push_back({{"iteration", r.iteration},
                 {"E", r.energy},
                 {"E_G", r.geometric},
                 {"E_D", r.discretization},
                 {"v", r.v},
                 {"moves", r.moves},
                 {"evaluations", r.evaluations},
                 {"swaps", r.swaps},
                 {"seconds", r.seconds},
                 {"node_seconds", r.node_seconds},
                 {"swap_seconds", r.swap_seconds}});
  return h;
}

namespace {
std::string vec(const json& a, const char* fmt = "%g") {
  std::string s;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, a[i].get<double>());
    s += (i ? " x " : "") + std::string(buf);
  }
  return s;
}
}  // namespace

void print_image_info(std::ostream& out, const json& im) {
  char buf[256];
  out << "  file:       " << im.value("file", std::string()) << "\n";
  out << "  size:       " << vec(im["size"], "%.0f") << " voxels (" << im["voxels"].get<double>() << ")\n";
  out << "  spacing:    " << vec(im["spacing"]) << "\n";
  out << "  extent:     " << vec(im["extent"]) << "  (voxel box, image units)\n";
  out << "  origin:     " << vec(im["origin"]) << "  (centre of voxel 0)\n";
  out << "  world box:  [" << vec(im["world_bounds"]["min"]) << "] .. [" << vec(im["world_bounds"]["max"])
      << "]\n";
  if (im.contains("world_centre"))
    out << "  centre:     " << vec(im["world_centre"]) << "  (world, centre of the voxel box)\n";
  // identity, axis-aligned (a permutation with signs: flipped or swapped axes, e.g. a NIfTI's LPS
  // flips) or oblique
  bool identity = true, aligned = true;
  const int dim = im["dimension"].get<int>();
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) {
      const double d = im["direction"][a * dim + b].get<double>();
      identity = identity && std::abs(d - (a == b ? 1.0 : 0.0)) < 1e-12;
      aligned = aligned && (std::abs(d) < 1e-12 || std::abs(std::abs(d) - 1.0) < 1e-12);
    }
  out << "  direction:  "
      << (identity ? std::string("identity")
                   : std::string(aligned ? "axis-aligned, flipped or permuted (" : "oblique (") +
                         vec(im["direction"], "%.4f") + ")")
      << "\n";
  const json& v = im["values"];
  std::snprintf(buf, sizeof buf, "  values:     min %.6g  max %.6g  mean %.6g  stddev %.6g\n",
                v["min"].get<double>(), v["max"].get<double>(), v["mean"].get<double>(),
                v["stddev"].get<double>());
  out << buf;
}

void print_summary(std::ostream& out, const json& r) {
  char buf[256];
  out << "vim-pipeline " << r["tool"].value("version", std::string()) << " — summary\n";
  if (r.contains("input")) {
    out << "input\n";
    print_image_info(out, r["input"]);
  }
  if (r.contains("mesh")) {
    const json& m = r["mesh"];
    std::snprintf(buf, sizeof buf, "mesh (%s)\n  nodes %ld, elements %ld\n",
                  m.value("mesher", std::string()).c_str(), m.value("nodes", 0L), m.value("elements", 0L));
    out << buf;
    if (m.contains("quality")) {
      const json& q = m["quality"];
      std::snprintf(buf, sizeof buf, "  %s %.2f..%.2f deg, min NRR %.3f, inverted %ld\n",
                    r["input"].value("dimension", 3) == 3 ? "dihedral" : "angles",
                    q.value("min_dihedral_deg", 0.0), q.value("max_dihedral_deg", 0.0),
                    q.value("min_nrr", 0.0), q.value("inverted", 0L));
      out << buf;
    }
  }
  if (r.contains("optimization")) {
    const json& o = r["optimization"];
    const json& h = o["history"];
    if (!h.empty()) {
      std::snprintf(buf, sizeof buf, "optimization\n  %d iterations, %s; E %.4g -> %.4g, E_D %.4g -> %.4g\n",
                    o.value("iterations", 0), o.value("converged", false) ? "converged" : "not converged",
                    h.front().value("E", 0.0), h.back().value("E", 0.0), h.front().value("E_D", 0.0),
                    h.back().value("E_D", 0.0));
      out << buf;
    }
  }
  if (r.contains("segmentation")) {
    const json& s = r["segmentation"];
    std::snprintf(buf, sizeof buf,
                  "segmentation (threshold %g)\n  %d components, object: %ld elements, volume %.6g\n",
                  s.value("threshold", 0.0), s.value("components", 0), s.value("object_elements", 0L),
                  s.value("object_volume", 0.0));
    out << buf;
  }
  if (r.contains("simulation") && r["simulation"].is_object()) {
    out << "simulation\n";
    for (const auto& [k, v] : r["simulation"].items())
      if (v.is_primitive()) out << "  " << k << ": " << v.dump() << "\n";
    if (r["simulation"].contains("compare_linear")) {  // --compare-linear
      const json& c = r["simulation"]["compare_linear"];
      out << "compare_linear (" << c.value("definition", std::string()) << ")\n";
      const auto line = [&](const std::string& what, const json& e) {
        const json& d = e["relative_difference"];
        if (d.is_number())
          std::snprintf(buf, sizeof buf, "  %s: %.4g\n", what.c_str(), d.get<double>());
        else
          std::snprintf(buf, sizeof buf, "  %s: - (neo-hookean value 0)\n", what.c_str());
        out << buf;
      };
      for (const auto& [name, e] : c["targets"].items()) line("target " + name, e);
      if (c.contains("axial_force")) {  // a needle: the last step's, and the largest over the steps
        line("axial force", c["axial_force"]);
        if (c["axial_force"]["largest_relative_difference"].is_number())
          line("axial force, largest over the steps",
               {{"relative_difference", c["axial_force"]["largest_relative_difference"]}});
      }
      for (const auto& e : c["reactions"])
        line("reaction " + e.value("condition", std::string()) + " " + e.value("region", std::string()), e);
      line("max_displacement", c["max_displacement"]);
    }
  }
  if (r.contains("timing")) {
    out << "time:";
    for (const auto& [k, v] : r["timing"].items()) {
      std::snprintf(buf, sizeof buf, " %s %.2fs", k.c_str(), v.get<double>());
      out << buf;
    }
    out << "\n";
  }
  if (r.contains("outputs")) {
    out << "outputs in " << r.value("out", std::string()) << ":";
    for (const auto& f : r["outputs"]) out << " " << f.get<std::string>();
    out << "\n";
  }
}

StageTimer::StageTimer(std::vector<StageTime>& times, std::string stage)
    : times_(times), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}

double StageTimer::stop() {
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  times_.push_back({stage_, s});
  return s;
}

template ImageSummary summarize<2>(const Image<2>&);
template ImageSummary summarize<3>(const Image<3>&);
template json image_json<2>(const OrientedImage<2>&, const std::string&);
template json image_json<3>(const OrientedImage<3>&, const std::string&);

}  // namespace vim::pipeline

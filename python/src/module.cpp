// vimpipeline._core: NumPy in and out of the pipeline adapter (pipeline_adapter.hpp). The GIL is released
// while reading, meshing, solving and writing; the progress callback takes it back for each call.
// Bad input raises ValueError (std::invalid_argument) with the CLI's message.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "pipeline_adapter.hpp"

namespace py = pybind11;
using namespace vim::python;

namespace {

template <typename T>
py::array_t<T> to_array(const std::vector<T>& v, const std::vector<py::ssize_t>& shape) {
  py::array_t<T> a(shape);
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::array_t<long> to_array(const std::vector<long>& v, py::ssize_t rows, py::ssize_t cols) {
  return to_array<long>(v, {rows, cols});
}

// An image given as {"values": array[z, y, x], "spacing", "origin", "direction", "source"} (x, y, z order,
// direction dim × dim or flat row-major, as SimpleITK gives it).
ImageData image_from(const py::dict& d) {
  ImageData im;
  const auto values = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(d["values"]);
  if (!values) throw std::invalid_argument("image: the array must hold numbers");
  im.dim = static_cast<int>(values.ndim());
  for (int a = im.dim - 1; a >= 0; --a) im.size.push_back(static_cast<long>(values.shape(a)));
  im.values.assign(values.data(), values.data() + values.size());
  auto doubles = [](const py::handle& h) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
    if (!a) throw std::invalid_argument("image: spacing, origin and direction must be numbers");
    return std::vector<double>(a.data(), a.data() + a.size());
  };
  im.spacing = doubles(d["spacing"]);
  im.origin = doubles(d["origin"]);
  im.direction = doubles(d["direction"]);
  im.source = py::cast<std::string>(d["source"]);
  return im;
}

py::dict image_to(const ImageData& im) {
  std::vector<py::ssize_t> shape(im.size.rbegin(), im.size.rend());
  py::dict d;
  d["values"] = to_array<float>(im.values, shape);
  d["spacing"] = py::tuple(py::cast(im.spacing));
  d["origin"] = py::tuple(py::cast(im.origin));
  d["direction"] = to_array<double>(im.direction, {im.dim, im.dim});
  d["source"] = im.source;
  return d;
}

// Mesh options from a dict holding only the keys the caller set.
MeshSettings settings_from(const py::dict& d) {
  MeshSettings s;
  auto has = [&](const char* k) { return d.contains(k) && !d[k].is_none(); };
  for_each_mesh_keyword(s.options, [&](const char* k, auto& field) {
    if (!has(k)) return;
    field = py::cast<std::decay_t<decltype(field)>>(d[k]);
    s.given.insert(k);
  });
  if (has("sizing")) s.sizing = image_from(d["sizing"]);
  if (has("labels")) s.labels = image_from(d["labels"]);
  if (has("labels_alone")) s.labels_alone = py::cast<bool>(d["labels_alone"]);
  if (has("label_modulus")) s.label_moduli = py::cast<std::vector<std::string>>(d["label_modulus"]);
  if (has("threshold")) s.threshold = py::cast<double>(d["threshold"]);
  if (has("mesher")) s.mesher = py::cast<std::string>(d["mesher"]);
  return s;
}

// The callback gets (stage, {"iteration", "E", "E_G", "E_D", "v", "moves", "swaps", "seconds"}).
py::dict iteration_dict(const IterationData& r) {
  py::dict d;
  d["iteration"] = r.iteration;
  d["E"] = r.energy;
  d["E_G"] = r.geometric;
  d["E_D"] = r.discretization;
  d["v"] = r.v;
  d["moves"] = r.moves;
  d["swaps"] = r.swaps;
  d["seconds"] = r.seconds;
  return d;
}

// `callback` outlives the returned function (both live in the binding's frame).
ProgressFunction progress_from(const py::object& callback) {
  if (callback.is_none()) return [](const IterationData&) {};
  PyObject* f = callback.ptr();
  return [f](const IterationData& r) {
    py::gil_scoped_acquire gil;
    py::reinterpret_borrow<py::object>(f)(r.stage, iteration_dict(r));
  };
}

py::dict history_of(const MeshData& m) {
  const auto n = static_cast<py::ssize_t>(m.history.size());
  py::array_t<long> iteration(n), moves(n), swaps(n);
  py::array_t<double> e(n), eg(n), ed(n), v(n), seconds(n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& r = m.history[static_cast<std::size_t>(i)];
    iteration.mutable_at(i) = r.iteration;
    moves.mutable_at(i) = r.moves;
    swaps.mutable_at(i) = r.swaps;
    e.mutable_at(i) = r.energy;
    eg.mutable_at(i) = r.geometric;
    ed.mutable_at(i) = r.discretization;
    v.mutable_at(i) = r.v;
    seconds.mutable_at(i) = r.seconds;
  }
  py::dict d;
  d["iteration"] = iteration;
  d["E"] = e;
  d["E_G"] = eg;
  d["E_D"] = ed;
  d["v"] = v;
  d["moves"] = moves;
  d["swaps"] = swaps;
  d["seconds"] = seconds;
  return d;
}

py::dict fields_of(const std::map<std::string, std::vector<double>>& fields) {
  py::dict d;
  for (const auto& [name, values] : fields)
    d[py::str(name)] = to_array<double>(values, {static_cast<py::ssize_t>(values.size())});
  return d;
}

py::dict needle_dict(const NeedleData& n, int dim, std::size_t targets, std::size_t nodes) {
  const auto steps = static_cast<py::ssize_t>(n.depth.size());
  const auto t = static_cast<py::ssize_t>(targets);
  const auto kept = static_cast<py::ssize_t>(nodes ? n.displacement.size() / (nodes * dim) : 0);
  py::dict d;
  d["name"] = n.name;
  d["depth"] = to_array<double>(n.depth, {steps});
  d["axial_force"] = to_array<double>(n.axial_force, {steps});
  d["lateral_force"] = to_array<double>(n.lateral_force, {steps});
  d["friction_force"] = to_array<double>(n.friction_force, {steps});
  d["tip_force"] = to_array<double>(n.tip_force, {steps});
  py::array_t<bool> tip_cutting(steps);
  for (py::ssize_t k = 0; k < steps; ++k)
    tip_cutting.mutable_at(k) =
        k < static_cast<py::ssize_t>(n.tip_cutting.size()) && n.tip_cutting[static_cast<std::size_t>(k)] != 0;
  d["tip_cutting"] = tip_cutting;
  py::list punctures;
  for (std::size_t p = 0; p + 2 < n.punctures.size(); p += 3) {
    py::dict one;
    one["depth"] = n.punctures[p];
    one["force_before"] = n.punctures[p + 1];
    one["force_after"] = n.punctures[p + 2];
    punctures.append(one);
  }
  d["punctures"] = punctures;
  d["max_strain"] = to_array<double>(n.max_strain, {steps});
  d["tip"] = to_array<double>(n.tip, {steps, dim});
  d["force"] = to_array<double>(n.force, {steps, dim});
  d["target_displacement"] = to_array<double>(n.target_displacement, {steps, t, dim});
  d["displacement"] = to_array<double>(n.displacement, {kept, static_cast<py::ssize_t>(nodes), dim});
  if (!n.shape.empty()) {  // needle.flexible
    d["tip_deviation"] = to_array<double>(n.tip_deviation, {steps, dim});
    d["tip_angle"] = to_array<double>(n.tip_angle, {steps});
    py::list shape;
    for (const auto& line : n.shape)
      shape.append(to_array<double>(line, {static_cast<py::ssize_t>(line.size()) / dim, dim}));
    d["needle_shape"] = shape;
  }
  return d;
}

void bind_mesh(py::module_& m) {
  py::class_<MeshData>(m, "MeshData")
      .def_property_readonly("dim", [](const MeshData& d) { return d.dim; })
      .def_property_readonly("points",
                             [](const MeshData& d) {
                               const auto n = static_cast<py::ssize_t>(d.points.size() / d.dim);
                               return to_array<double>(d.points, {n, d.dim});
                             })
      .def_property_readonly("cells",
                             [](const MeshData& d) {
                               const py::ssize_t k = d.dim + 1;
                               return to_array(d.cells, static_cast<py::ssize_t>(d.cells.size()) / k, k);
                             })
      .def_property_readonly("cell_data", [](const MeshData& d) { return fields_of(d.cell_data); })
      .def_property_readonly("point_data", [](const MeshData& d) { return fields_of(d.point_data); })
      .def_property_readonly("history", &history_of)
      .def_property_readonly("warnings", [](const MeshData& d) { return d.warnings; })
      .def("write_vtu", [](const MeshData& d, const std::string& path) {
        py::gil_scoped_release release;
        write_vtu(d, path);
      });
}

// result.seeds: arrays over the procedure's seeds (SeedData).
py::dict seeds_dict(const SeedData& s, int dim) {
  const auto k = static_cast<py::ssize_t>(s.depth.size());
  py::array_t<double> norm(k);
  for (py::ssize_t i = 0; i < k; ++i) {
    double sq = 0.0;
    for (int a = 0; a < dim; ++a) sq += std::pow(s.error[static_cast<std::size_t>(i * dim + a)], 2);
    norm.mutable_at(i) = std::sqrt(sq);
  }
  py::dict d;
  d["needle"] = s.needle;
  d["depth"] = to_array<double>(s.depth, {k});
  d["planned"] = to_array<double>(s.planned, {k, dim});
  d["final"] = to_array<double>(s.final_position, {k, dim});
  d["error"] = to_array<double>(s.error, {k, dim});
  d["error_norm"] = norm;
  d["release_step"] = to_array<int>(s.release_step, {k});
  return d;
}

void bind_simulation(py::module_& m) {
  py::class_<SimulationData>(m, "SimulationData")
      .def_property_readonly("mesh", [](const SimulationData& s) { return s.mesh; })
      .def_property_readonly("needles",
                             [](const SimulationData& s) {
                               py::list l;
                               const std::size_t nodes = s.mesh.points.size() / s.mesh.dim;
                               for (const auto& n : s.needles)
                                 l.append(needle_dict(n, s.mesh.dim, s.target_names.size(), nodes));
                               return l;
                             })
      .def_property_readonly("seeds", [](const SimulationData& s) { return seeds_dict(s.seeds, s.mesh.dim); })
      .def_property_readonly("target_names", [](const SimulationData& s) { return s.target_names; })
      .def_property_readonly("warnings", [](const SimulationData& s) { return s.warnings; })
      .def_property_readonly("files", [](const SimulationData& s) { return s.files; })
      .def_property_readonly("report_json", [](const SimulationData& s) { return s.report_json; });
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "vim-pipeline bindings: image IO, VIM meshing and needle-insertion simulation";
  m.attr("__version__") = version();
  bind_mesh(m);
  bind_simulation(m);
  // The mesh keywords' defaults: MeshOptions', the CLI's (vimpipeline.mesh's signature reads them).
  m.def("mesh_defaults", [] {
    const vp::MeshOptions defaults;
    py::dict d;
    for_each_mesh_keyword(defaults, [&](const char* k, const auto& value) { d[k] = value; });
    return d;
  });
  m.def("read_image", [](const std::string& path) {
    ImageData im;
    {
      py::gil_scoped_release release;
      im = read_image(path);
    }
    return image_to(im);
  });
  m.def("mesh", [](const py::dict& image, const py::dict& settings, const py::object& progress) {
    const ImageData im = image_from(image);
    const MeshSettings s = settings_from(settings);
    const ProgressFunction report = progress_from(progress);
    py::gil_scoped_release release;
    return mesh(im, s, report);
  });
  m.def("fit_forces", [](const std::string& image, const py::dict& settings, const std::string& scenario,
                         const std::string& measured, const std::string& out, bool overwrite) {
    const MeshSettings s = settings_from(settings);
    py::gil_scoped_release release;
    return fit_forces(image, s, scenario, measured, out, overwrite);
  });
  m.def("simulate",
        [](const py::object& image, const MeshData* premeshed, const py::dict& settings,
           const std::string& scenario_path, const std::string& scenario_text,
           const std::string& scenario_name, const std::string& staging_dir, const py::object& progress) {
          std::optional<ImageData> im;
          if (!image.is_none()) im = image_from(image.cast<py::dict>());
          const MeshSettings s = settings_from(settings);
          const ProgressFunction report = progress_from(progress);
          py::gil_scoped_release release;
          return simulate(im ? &*im : nullptr, premeshed, s, {scenario_path, scenario_text, scenario_name},
                          staging_dir, report);
        });
}

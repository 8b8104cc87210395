// The Python module's view of the pipeline: plain data (row-major arrays in std::vector, no Eigen, no
// pybind11) in and out. Every call into the pipeline and the mesher is made in pipeline_adapter.cpp;
// module.cpp only converts these structs to and from NumPy.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>
#include <vim/pipeline/scenario/mesh_options.hpp>
#include <vim/vim.hpp>

namespace vim::python {

namespace vp = vim::pipeline;

// A scalar image as ITK holds it: axis 0 (x) varies fastest in `values`.
struct ImageData {
  int dim = 3;
  std::vector<long> size;         // voxels per axis (x, y[, z])
  std::vector<double> spacing;    // per axis (x, y[, z])
  std::vector<double> origin;     // centre of voxel 0, world
  std::vector<double> direction;  // dim × dim, row-major: column c is image axis c in world axes (ITK)
  std::vector<float> values;
  std::string source = "array";  // file name, or "array" (names the image in error messages)
};

// vimpipeline.mesh's options: the keywords the caller gave over MeshOptions' defaults (the CLI's); in
// simulate(), a scenario's mesh keys apply to those not given.
struct MeshSettings {
  vp::MeshOptions options;
  std::set<std::string> given;  // the Python keywords set (names as in for_each_mesh_keyword)
  std::optional<ImageData> sizing;
  std::optional<ImageData> labels;        // beside the image (--labels LABELS)
  bool labels_alone = false;              // the image is the label image (--labels IMAGE)
  std::vector<std::string> label_moduli;  // --label-modulus LABEL=E
  std::optional<double> threshold;
  std::string mesher = "vim";  // vim | grid
  bool has(const std::string& keyword) const { return given.count(keyword) > 0; }
};

// Every numeric mesh keyword of the Python API with its MeshOptions field: f(keyword, field). One list
// for reading the keywords and for the module's defaults (vimpipeline.mesh's signature reads them).
template <class Options, class F>
void for_each_mesh_keyword(Options& o, F&& f) {
  f("nodes", o.nodes);
  f("spacing", o.spacing);
  f("lam", o.lambda);
  f("max_dihedral", o.max_dihedral_deg);
  f("min_dihedral", o.min_dihedral_deg);
  f("min_radius_ratio", o.min_radius_ratio);
  f("max_iterations", o.max_iterations);
  f("convergence", o.convergence);
  f("energy_convergence", o.energy_convergence);
  f("search_width", o.search_width);
  f("seed", o.seed);
  f("threads", o.threads);
  f("degree", o.degree);
}

// One line of the energy history (history[0] is the initial mesh), or one progress report.
struct IterationData {
  std::string stage;  // "sizing" or "vim"
  int iteration = 0;
  double energy = 0.0, geometric = 0.0, discretization = 0.0, v = 0.0, seconds = 0.0;
  long moves = 0, swaps = 0;
};

// Called after each meshing iteration and at each pipeline stage (iteration 0), with the GIL released
// by the caller; the callee acquires what it needs.
using ProgressFunction = std::function<void(const IterationData&)>;

// The meshed model (mesher and images kept for simulate() and write_vtu()).
struct MeshState;

struct MeshData {
  int dim = 3;
  std::vector<double> points;  // n × dim, world coordinates (as mesh.vtu)
  std::vector<long> cells;     // m × (dim + 1), positively oriented in the world (as mesh.vtu)
  std::map<std::string, std::vector<double>>
      cell_data;  // mean, variance, voxels, quality[, segment, object, youngs_modulus]
  std::map<std::string, std::vector<double>> point_data;  // boundary
  std::vector<IterationData> history;
  std::vector<std::string> warnings;
  std::shared_ptr<const MeshState> state;
};

struct NeedleData {
  std::string name;
  std::vector<double> depth, axial_force, lateral_force;  // per step
  std::vector<double> friction_force, tip_force;          // per step: the axial force's two parts
  std::vector<int> tip_cutting;             // per step: 1 where the tip cuts (at its cutting force)
  std::vector<double> punctures;            // per puncture: depth, force before, force after
  std::vector<double> max_strain;           // per step: largest principal strain
  std::vector<double> tip, force;           // steps × dim, world
  std::vector<double> target_displacement;  // steps × targets × dim, world axes
  std::vector<double> displacement;         // steps × nodes × dim, world axes
  // needle.flexible (empty for a rigid needle): per step the tip's deviation from the planned line
  // (steps × dim), its angle to it (degrees) and the needle's shape (points × dim, holder to tip).
  std::vector<double> tip_deviation, tip_angle;
  std::vector<std::vector<double>> shape;
};

// A procedure's seeds (seeds.csv), needle by needle in their planned depths' order: the needle's name,
// the planned depth, and (seeds × dim, world) the planned and final positions and the error (final −
// planned); the withdrawal step of the release.
struct SeedData {
  std::vector<std::string> needle;
  std::vector<double> depth, planned, final_position, error;
  std::vector<int> release_step;
};

struct SimulationData {
  MeshData mesh;  // with cell data youngs_modulus
  std::vector<NeedleData> needles;
  SeedData seeds;
  std::vector<std::string> target_names, warnings, files;  // files: written under the staging folder
  std::string report_json;                                 // report.json as written
};

// The scenario: a YAML file, or YAML/JSON text with a name for messages.
struct ScenarioSource {
  std::string path;
  std::string text;
  std::string name;
};

ImageData read_image(const std::string& path);
MeshData mesh(const ImageData& image, const MeshSettings& settings, const ProgressFunction& progress);
// Writes the mesh as the CLI writes mesh.vtu.
void write_vtu(const MeshData& mesh, const std::string& path);
// Meshes `image` with `settings` (the scenario's mesh keys fill unset ones), or takes `premeshed`, then
// runs the scenario; writes the CLI's files into `staging_dir` (an existing empty folder).
SimulationData simulate(const ImageData* image, const MeshData* premeshed, const MeshSettings& settings,
                        const ScenarioSource& scenario, const std::string& staging_dir,
                        const ProgressFunction& progress);
// `vim-pipeline IMAGE --simulate SCENARIO --fit-forces MEASURED --out OUT` with the mesh settings
// (fit/fit_run.hpp); returns the text of OUT/fit.json.
std::string fit_forces(const std::string& image, const MeshSettings& settings, const std::string& scenario,
                       const std::string& measured, const std::string& out, bool overwrite);
// The project version (CMake project version).
std::string version();

}  // namespace vim::python

// PipelineRun, stage 1 (pipeline_run.hpp): the inputs. The scenario and the output folder are checked
// in the constructor, before any work; read_inputs() reads the image (its header was read once by
// ImageFile), the sizing image, and checks the scenario against the image box once.
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>

#include "run/run_support.hpp"

namespace vim::pipeline {

std::string fmt(const char* f, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, f);
  std::vsnprintf(buf, sizeof buf, f, ap);
  va_end(ap);
  return buf;
}

namespace {

// The scenario's mesh keys apply where the option was not given on the command line.
RunOptions with_scenario_mesh_keys(const RunOptions& given, const std::optional<Scenario>& sc) {
  if (!sc) return given;
  RunOptions o = given;
  static_cast<MeshOptions&>(o) = with_scenario_mesh(given, *sc, [&](const std::string& flag) {
    for (const auto& a : given.command_line)
      if (a == flag || a.rfind(flag + "=", 0) == 0) return true;
    return false;
  });
  return o;
}

template <int dim>
void check_meshable(const OrientedImage<dim>& img, const std::string& file) {
  for (int a = 0; a < dim; ++a)
    if (img.image.size[a] < 2) {
      std::string sz;
      for (int b = 0; b < dim; ++b) sz += (b ? " x " : "") + std::to_string(img.image.size[b]);
      throw InputError(file + ": image is 1 voxel thick along axis " + std::to_string(a) + " (size " + sz +
                       "); meshing needs at least 2 voxels per axis (store a single slice as a 2D image)");
    }
}

// The voxel sums behind every element mean (prefix sums in double precision, shifted by the image
// mean) are accurate to about N·ε·max|value − mean| for N voxels. With a few huge values among
// ordinary ones (1e20 next to 15) that is larger than the ordinary values themselves: a warning then.
template <int dim>
std::optional<std::string> value_accuracy_warning(const Image<dim>& image, const std::string& file) {
  const ImageSummary values = summarize(image);
  const double spread = std::max(values.max - values.mean, values.mean - values.min);
  std::vector<float> v(image.data.size());
  std::transform(image.data.begin(), image.data.end(), v.begin(), [](float x) { return std::abs(x); });
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  const double typical = v[v.size() / 2];
  const double accuracy = static_cast<double>(v.size()) * 2.2e-16 * spread;
  if (!(typical > 0.0 && accuracy > 1e-3 * typical)) return std::nullopt;
  return fmt(
      "%s: the values span up to %.3g from their mean while half of them are below %.3g in magnitude: "
      "element means are accurate only to about %.2g, %.2g%% of a typical value (check the image's "
      "units or clamp outliers)",
      file.c_str(), spread, typical, accuracy, 100.0 * accuracy / typical);
}

}  // namespace

template <int dim>
PipelineRun<dim>::PipelineRun(const RunOptions& given, ImageFile image, RunRanks ranks)
    : scenario_(given.simulate.empty() ? std::nullopt
                                       : std::optional<Scenario>(read_scenario(given.simulate, dim))),
      options_(with_scenario_mesh_keys(given, scenario_)),
      ranks_(std::move(ranks)),
      image_file_(std::move(image)),
      start_(std::chrono::steady_clock::now()),
      // refuses a non-empty DIR before any work; the ranks other than 0 of a run over MPI ranks have none
      out_(options_.out.empty() && ranks_.size > 1
               ? nullptr
               : std::make_unique<OutputDirectory>(options_.out, options_.overwrite)) {
  if (image_file_->dimension() != dim)
    throw std::invalid_argument(image_file_->path() + ": a " + std::to_string(image_file_->dimension()) +
                                "D image given to a " + std::to_string(dim) + "D run");
}

template <int dim>
PipelineRun<dim>::PipelineRun(const RunOptions& given, RunInputs<dim> inputs, RunRanks ranks)
    : scenario_(std::move(inputs.scenario)),
      options_(with_scenario_mesh_keys(given, scenario_)),
      ranks_(std::move(ranks)),
      inputs_(std::move(inputs)),
      start_(std::chrono::steady_clock::now()),
      out_(options_.out.empty() ? nullptr
                                : std::make_unique<OutputDirectory>(options_.out, options_.overwrite)) {}

template <int dim>
PipelineRun<dim>::~PipelineRun() = default;

template <int dim>
OutputDirectory& PipelineRun<dim>::out() {
  if (!out_) throw std::logic_error("PipelineRun: this run has no output folder (RunOptions::out)");
  return *out_;
}

// A warning of the run: on stderr (unless --quiet) and in the warnings of the stage's result (report.json
// "warnings").
template <int dim>
void PipelineRun<dim>::warn(std::vector<std::string>& warnings, const std::string& stage,
                            const std::string& message) {
  Log::warning(stage, message);
  warnings.push_back(message);
}

template <int dim>
const InputsResult& PipelineRun<dim>::read_inputs() {
  const RunOptions& o = options_;
  InputsResult& result = inputs_result_;
  StageTimer t_read(result.timing, "read_image");
  image_ = image_file_ ? image_file_->read<dim>() : std::move(inputs_->image);
  t_read.stop();
  const OrientedImage<dim>& img = *image_;
  result.image = image_json(img, o.image);
  check_meshable(img, o.image);
  read_label_image();
  if (const auto w = value_accuracy_warning(img.image, o.image)) warn(result.warnings, "input", *w);
  if (o.mesher != MesherKind::voxel && o.spacing <= 0.0 && o.nodes < (1L << dim))
    throw InputError("--nodes " + std::to_string(o.nodes) + ": a " + std::to_string(dim) +
                     "D mesh needs at least " + std::to_string(1 << dim) + " nodes (2 per axis)");
  o.vim_options().validate();
  read_sizing_image();
  model_.transform.origin = img.origin();
  model_.transform.direction = img.direction;
  check_scenario();
  // Every input is checked; from here on progress goes to stderr.
  Log::info("image", fmt("%s: %dD, %zu voxels, values %.4g..%.4g", o.image.c_str(), dim,
                         img.image.voxel_count(), result.image["values"]["min"].template get<double>(),
                         result.image["values"]["max"].template get<double>()));
  return result;
}

// --sizing: a density image in IMAGE's frame (§VI-E), positive everywhere.
template <int dim>
void PipelineRun<dim>::read_sizing_image() {
  const RunOptions& o = options_;
  if (inputs_) {
    sizing_ = std::move(inputs_->sizing);
    if (!sizing_) return;
  } else {
    if (o.sizing.empty()) return;
    const ImageFile file(o.sizing);
    if (file.dimension() != dim)
      throw InputError(o.sizing + ": sizing image is " + std::to_string(file.dimension()) +
                       "D but IMAGE is " + std::to_string(dim) + "D; they must match");
    sizing_ = file.read<dim>();
  }
  const ImageSummary s = summarize(sizing_->image);
  if (!(s.min > 0.0))
    throw InputError(o.sizing + ": sizing image has values <= 0 (min " + std::to_string(s.min) +
                     "); density must be positive everywhere");
  if (!sizing_->direction.isApprox(image_->direction, 1e-6))
    throw InputError(o.sizing + ": sizing image direction differs from IMAGE's; both must share one frame");
  inputs_result_.sizing = image_json(*sizing_, o.sizing);
  sizing_->image = in_frame_of(*image_, *sizing_);
}

// The scenario against the image (once: the simulation is told it is checked), the degree and
// locking warnings, and the needle-path density of mesh.needle_refinement.
template <int dim>
void PipelineRun<dim>::check_scenario() {
  const RunOptions& o = options_;
  if (!scenario_) return;
  const Scenario& sc = *scenario_;
  check_scenario_geometry<dim>(sc, image_->image.box_min(), image_->image.box_max(), model_.transform);
  check_modulus_image<dim>(sc, image_->image);
  if (o.degree == 2 && o.mesher == MesherKind::voxel)
    warn(inputs_result_.warnings, "simulate",
         "--mesher voxel builds the voxel reference model of trilinear hexahedra (Q1) whatever the degree; "
         "--degree 2 applies to the simplex meshes (vim, grid)");
  if (o.degree == 1 && o.mesher != MesherKind::voxel && sc.poisson_ratio >= kLockingPoisson) {
    // Linear tetrahedra lock for nearly incompressible material: the displacements come out too small
    // on the coarse meshes VIM is for (docs/validation.md, "Why VIM lost at 80 nodes").
    std::ostringstream m;
    m << sc.source << ": material.poisson_ratio = " << std::setprecision(12) << sc.poisson_ratio
      << " with linear (degree 1) elements: " << (dim == 3 ? "P1 tetrahedra" : "P1 triangles (plane strain)")
      << " lock for poisson_ratio >= " << kLockingPoisson
      << ", so the displacements come out too small on coarse meshes (and towards 0.5 the needle forces can "
         "be "
         "wildly wrong, even of the wrong sign); set mesh.degree: 2 in the scenario"
      << " (or --degree 2) for quadratic elements (about 5x the solve time)";
    warn(inputs_result_.warnings, "simulate", m.str());
  }
  // mesh.needle_refinement: a density around the needle paths that VIM keeps in E_G (§VI-E).
  if (sc.needle_refinement && o.mesher == MesherKind::vim) {
    if (sizing_)
      throw InputError("--sizing " + o.sizing + " and " + sc.source +
                       ": mesh.needle_refinement both set the mesh density; give only one of them");
    const auto& nr = *sc.needle_refinement;
    needle_density_ = needle_refinement_density<dim>(sc, image_->image, model_.transform);
    inputs_result_.needle_refinement = InputsResult::NeedleRefinement{
        nr.size_ratio, nr.radius, std::pow(nr.size_ratio, -static_cast<double>(dim + 2))};
  }
}

template class PipelineRun<2>;
template class PipelineRun<3>;

}  // namespace vim::pipeline

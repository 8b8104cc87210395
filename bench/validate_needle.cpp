// Prostate scenario (docs/validation.md): VIM vs regular grid (same node count) against the fine voxel
// reference (one Q1 cell per voxel, E = voxel value) on the prostate phantom, for
//   (a) the needle insertion of examples/prostate_needle.yaml (NeedleSimulation, same scenario for
//       all three models; the embedded shaft points are sampled per mesh, see the doc), and
//   (b) a compression load: x_max face clamped, x_min face pushed by 5% of the length along +x
//       (other components free), ν and Eq. 15 moduli as in the scenario.
// Error metrics: relative L2 = sqrt(Σ|u − u_ref|² / Σ|u_ref|²) over voxel centres (all, and those in
// the gland ellipsoid), max |u − u_ref| / max |u_ref| over all voxel centres, and |u − u_ref| at each
// scenario target (needle only).
//
//   validate_needle [--n 40] [--steps 12] [--scenario examples/prostate_needle.yaml]
//                   [--plots DIR] [--skip-needle] [--skip-compression] [nodes ...]
// Diagnostics (same options for the VIM and the grid model; the reference never changes with them
// except through --nu): [--lambda L] [--min-dihedral D] [--min-rr R] [--max-dihedral D] [--no-swaps]
// [--degree D] (default: the scenario's) [--nu 0.3] [--ref-cache FILE] (reuse the compression reference of an
// earlier run). Needle diagnostics: [--near-radius R] (the "far" error leaves out voxel centres within R mm
// of the needle path; default 4), [--shaft] (each shaft point's final axial force over its friction limit),
// [--sample-spacing S] (the same shaft point pitch, in mm, for all three models).
// Probe support: [--support-stiffness K] (every fixed volume region, e.g. the probe cylinder, becomes an
// elastic support of stiffness K kPa/mm² for all three models; 0 clamps the nodes in it),
// [--support-spacing H] (its sample lattice pitch in mm).
// [--cutting-distance C] (the needle's cutting distance in mm, all three models; default: the scenario's).
// [--coupling-radius R] (the needle bands' radius in mm for every model and the reference; default: each
// model's own from its element size near the path). [--ref-study N] (repeatable: the needle reference
// on the phantom at N voxels too, compared with the main one: the reference's own refinement study).
// Every needle experiment also runs the grid graded by the needle density (the "graded grid").
#include <deal.II/base/mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/output/figures.hpp>
#include <vim/pipeline/scenario/mesh_options.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/quality.hpp>
#include <vim/sizing.hpp>
#include <vim/vim.hpp>
#include <vim/voxel_statistics.hpp>

namespace {

using namespace vim;
using namespace vim::pipeline;
using vim::needle::NeedlePath;
using V3 = Eigen::Vector3d;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Samples {
  std::vector<V3> points;   // frame coordinates (voxel centres)
  std::vector<bool> gland;  // inside the gland ellipsoid
  std::vector<bool> far;    // farther than --near-radius from the needle path (segment entry..tip)
};

struct Err {
  double rel_all = 0, rel_gland = 0, max_rel = 0, rel_far = 0;
  std::vector<double> target;  // |u − u_ref| at each target (needle)
};

Err compare(const std::vector<V3>& u, const std::vector<V3>& ref, const Samples& s) {
  Err e;
  double na = 0, da = 0, ng = 0, dg = 0, nf = 0, df = 0, mx = 0, mref = 0;
  for (std::size_t k = 0; k < ref.size(); ++k) {
    const double d2 = (u[k] - ref[k]).squaredNorm(), r2 = ref[k].squaredNorm();
    na += d2, da += r2;
    if (s.gland[k]) ng += d2, dg += r2;
    if (s.far.empty() || s.far[k]) nf += d2, df += r2;
    mx = std::max(mx, std::sqrt(d2));
    mref = std::max(mref, std::sqrt(r2));
  }
  e.rel_all = da > 0 ? std::sqrt(na / da) : 0.0;
  e.rel_gland = dg > 0 ? std::sqrt(ng / dg) : 0.0;
  e.max_rel = mref > 0 ? mx / mref : 0.0;
  e.rel_far = df > 0 ? std::sqrt(nf / df) : 0.0;
  return e;
}

struct Meshes {
  std::size_t nodes = 0, cells_grid = 0, cells_vim = 0;
  MeshModel<3> grid, vim;
  std::optional<MeshModel<3>> graded;  // the grid graded by the needle density (needle experiment)
  double vim_seconds = 0;
};

// The regular grid graded across the needle by the scenario's needle density (pipeline's
// needle_refinement_density: ρ(d) = 1 + (ρ_max − 1)·exp(−(d/radius)²), element size ∝ ρ^(−1/5)): along
// each axis other than the needle's, the node coordinates follow that size as a function of the
// distance to the path on that axis, so the nodes per axis (and the node count) stay those of the grid.
// A needle not along a grid axis leaves the grid as it is.
SimplexMesh<3> graded_grid(SimplexMesh<3> grid, const V3& lo, const V3& hi, const NeedlePath<3>& path,
                           const Scenario::NeedleRefinement& nr) {
  int along = 0;
  if (path.axis.cwiseAbs().maxCoeff(&along) < 1.0 - 1e-9) return grid;
  const double rho_max = std::pow(nr.size_ratio, -5.0);
  constexpr int kTable = 4096;
  for (int a = 0; a < 3; ++a) {
    if (a == along) continue;
    // ξ(y) = ∫ 1/size: uniform in ξ is graded in y; tabulated, normalised to [lo, hi], then inverted.
    std::vector<double> y(kTable + 1), xi(kTable + 1, 0.0);
    auto inverse_size = [&](double t) {
      const double d = (t - path.entry[a]) / nr.radius;
      return std::pow(1.0 + (rho_max - 1.0) * std::exp(-d * d), 0.2);
    };
    for (int k = 0; k <= kTable; ++k) {
      y[k] = lo[a] + (hi[a] - lo[a]) * k / kTable;
      if (k) xi[k] = xi[k - 1] + 0.5 * (inverse_size(y[k - 1]) + inverse_size(y[k])) * (y[k] - y[k - 1]);
    }
    for (double& v : xi) v = lo[a] + (hi[a] - lo[a]) * v / xi.back();
    for (auto& p : grid.points) {
      const auto k = std::clamp<long>(std::upper_bound(xi.begin(), xi.end(), p[a]) - xi.begin(), 1, kTable);
      const double w = (p[a] - xi[k - 1]) / (xi[k] - xi[k - 1]);
      p[a] = y[k - 1] + w * (y[k] - y[k - 1]);
    }
  }
  return grid;
}

// Mesh diagnostics: quality and how many cells resolve the stiff structures.
const Scenario* g_scenario = nullptr;  // for the region node counts in describe()
bool g_shaft = false;                  // --shaft: print every shaft point's final force and limit

void describe(const char* name, const MeshModel<3>& m) {
  const MeshQuality q = mesh_quality<3>(m.mesh);
  std::string regions;
  if (g_scenario)
    for (const auto& bc : g_scenario->boundary_conditions) {
      if (bc.region.kind != RegionSpec::Kind::cylinder) continue;
      const auto reg = fem::cylinder_region<3>(V3(bc.region.center.data()), V3(bc.region.axis_vector.data()),
                                               bc.region.radius, bc.region.length);
      long hits = 0;
      for (const auto& p : m.mesh.points) hits += reg.contains(m.transform.to_world(p));
      regions += ", nodes in the " + bc.region.describe() + ": " + std::to_string(hits);
    }
  long gland = 0, lesion = 0, empty = 0;
  for (const auto& v : m.values) {
    gland += v.mean > 37.5;
    lesion += v.mean > 105.0;
    empty += v.voxels == 0;
  }
  std::printf(
      "  %s: %zu cells, dihedral %.1f..%.1f deg, min NRR %.3f, cells with mean > 37.5 kPa: %ld, "
      "> 105 kPa: %ld, without a voxel centre: %ld%s\n",
      name, m.mesh.n_cells(), q.min_dihedral_deg, q.max_dihedral_deg, q.min_nrr, gland, lesion, empty,
      regions.c_str());
}

// `labels`: the phantom's anatomy labels on the image's grid, for the scenario's label regions (its needle
// tissues).
Meshes make_meshes(const OrientedImage<3>& img, long budget, const VimOptions& vo, const Image<3>* density,
                   const Scenario& sc, const WorldTransform<3>& tf, std::shared_ptr<const Image<3>> labels) {
  Meshes m;
  const auto lo = img.image.box_min(), hi = img.image.box_max();
  const auto axis = nodes_per_axis_for_budget<3>(lo, hi, budget);
  const SimplexMesh<3> initial = regular_grid_mesh<3>(lo, hi, axis);
  const VoxelStatistics<3> stats(img.image);
  const auto t = Clock::now();
  // As the CLI: with a needle density, a density-weighted E_G initialisation, then VIM keeping it.
  VimResult<3> r =
      density ? optimize_sized<3>(img.image, *density, initial, vo) : optimize<3>(img.image, initial, vo);
  for (MeshModel<3>* mm : {&m.grid, &m.vim}) {
    mm->transform.origin = img.origin();
    mm->transform.direction = img.direction;
    mm->label_image = labels;
  }
  m.grid.mesh = initial;
  for (std::size_t c = 0; c < initial.n_cells(); ++c)
    m.grid.values.push_back(stats.value(cell_points(initial, c)));
  m.vim_seconds = since(t);
  m.vim.mesh = std::move(r.mesh);
  m.vim.values = std::move(r.values);
  if (density && sc.needle_refinement) {
    m.graded = m.grid;
    m.graded->mesh = graded_grid(initial, lo, hi, needle_paths<3>(sc, tf).at(0), *sc.needle_refinement);
    m.graded->values.clear();
    for (std::size_t c = 0; c < m.graded->mesh.n_cells(); ++c)
      m.graded->values.push_back(stats.value(cell_points(m.graded->mesh, c)));
  }
  m.nodes = initial.n_points();
  m.cells_grid = initial.n_cells();
  m.cells_vim = m.vim.mesh.n_cells();
  return m;
}

// ---- compression -------------------------------------------------------------------------------
constexpr double kStrain = 0.05;

void add_compression(fem::ElasticModel<3>& model, const V3& lo, const V3& hi) {
  const double tol = 1e-6 * (hi - lo).norm();
  model.add_dirichlet(fem::DirichletBC<3>{fem::box_face_region<3>(lo, hi, 0, true, tol)});
  fem::DirichletBC<3> push{fem::box_face_region<3>(lo, hi, 0, false, tol)};
  push.components = fem::DirichletBC<3>::filled(false);
  push.components[0] = true;
  push.value = V3(kStrain * (hi[0] - lo[0]), 0, 0);
  model.add_dirichlet(push);
}

std::vector<V3> solve_compression(const MeshModel<3>& m, const Scenario& sc, const V3& lo, const V3& hi,
                                  const Samples& s, double* energy, unsigned degree) {
  std::vector<double> mean;
  for (const auto& v : m.values) mean.push_back(v.mean);
  fem::ElasticModel<3> model(m.mesh, scenario_modulus(sc, mean), sc.poisson_ratio, degree);
  add_compression(model, lo, hi);
  const auto sol = model.solve();
  if (energy) *energy = sol.strain_energy;
  return model.sample(s.points);
}

// ---- needle ------------------------------------------------------------------------------------
struct NeedleOut {
  std::vector<V3> u;        // at the sample points (frame axes = world axes: identity direction)
  std::vector<V3> targets;  // final target displacement (world)
  double axial_force = 0, seconds = 0;
  int shaft_points = 0;
};

NeedleOut finish(NeedleSimulation<3>& sim, const Samples& s) {
  const auto t = Clock::now();
  const SimulationResult<3> r = sim.run();
  NeedleOut o;
  o.seconds = since(t);
  o.u = sim.model().sample(s.points);
  o.targets = r.needles.at(0).target_displacement.back();
  o.axial_force = r.needles.at(0).axial_force.back();
  o.shaft_points = static_cast<int>(r.needles.at(0).point_s.size());
  if (g_shaft) {
    const auto& nr = r.needles.at(0);
    const double limit = g_scenario ? g_scenario->needles.at(0).max_shear_per_length : 0.0;
    std::printf("  shaft (s, length, final axial force / (limit x length)):");
    for (std::size_t j = 0; j < nr.point_s.size(); ++j)
      std::printf(" [%.1f %.2f %.3f]", nr.point_s[j], nr.point_length[j],
                  nr.point_axial_force.back()[j] / (limit * nr.point_length[j]));
    std::printf("\n");
  }
  return o;
}

// The voxel reference of the needle on the phantom at `n` voxels along x (its own refinement study),
// sampled at the same world points and compared with `ref`.
void reference_on_other_image(int n, const Scenario& sc, const SimulationOptions& opt, const Samples& s,
                              const WorldTransform<3>& tf, const NeedleOut& ref) {
  const OrientedImage<3> img = phantoms::prostate(n);
  WorldTransform<3> other;
  other.origin = img.origin();
  other.direction = img.direction;
  Samples at = s;
  for (V3& p : at.points) p = other.to_frame(tf.to_world(p));
  const auto t = Clock::now();
  auto sim = NeedleSimulation<3>::voxel(img.image, other, sc, opt,
                                        std::make_shared<const Image<3>>(phantoms::prostate_labels(n).image));
  const NeedleOut o = finish(sim, at);
  const Err e = compare(o.u, ref.u, s);
  std::printf(
      "reference on %d voxels (%.2f mm, %u DoFs, %.1f s): axial force %.2f mN, relL2 vs the reference %.4f "
      "(far %.4f), targets |u|:",
      n, img.image.spacing[0], sim.model().n_dofs(), since(t), o.axial_force, e.rel_all, e.rel_far);
  for (std::size_t k = 0; k < sc.targets.size(); ++k)
    std::printf(" %s %.4f", sc.targets[k].name.c_str(), o.targets[k].norm());
  std::printf("\n");
  std::fflush(stdout);
}

struct ModelRow {
  double rel = NAN, far = NAN;  // relative L2 error, all voxel centres and those far from the path
};
double rows_vim = NAN;  // the last VIM row's relL2 (for the plot)

// One row of the needle table: the model's run against the reference; `controls` (grid, graded grid)
// give the VIM row its ratio columns.
ModelRow needle_row(const char* name, std::size_t nodes, const MeshModel<3>& mm, const Scenario& sc,
                    const SimulationOptions& opt, const Samples& s, const NeedleOut& ref,
                    const std::vector<ModelRow>& controls) {
  std::optional<NeedleSimulation<3>> sim;
  try {
    sim.emplace(mm, sc, opt);
  } catch (const ScenarioError& e) {  // e.g. a region that selects no node of a coarse mesh
    std::printf("| %zu | %s | rejected: %s |\n", nodes, name, e.what());
    return {};
  }
  const NeedleOut o = finish(*sim, s);
  const Err e = compare(o.u, ref.u, s);
  std::printf("| %zu | %s | %d | %.4f | %.4f | %.4f | %.4f | %.2f |", nodes, name, o.shaft_points, e.rel_all,
              e.rel_gland, e.rel_far, e.max_rel, o.axial_force);
  for (std::size_t k = 0; k < sc.targets.size(); ++k)
    std::printf(" %.4f |", (o.targets[k] - ref.targets[k]).norm());
  for (const ModelRow& c : controls) std::printf(" **%.3f** | %.3f |", e.rel_all / c.rel, e.rel_far / c.far);
  for (std::size_t k = controls.size(); k < 2; ++k) std::printf(" | |");
  std::printf("\n");
  std::fflush(stdout);
  if (!controls.empty()) rows_vim = e.rel_all;
  return {e.rel_all, e.rel_far};
}

void plot(const std::string& dir, const std::string& name, const std::vector<double>& nodes,
          const std::vector<double>& vim, const std::vector<double>& grid,
          const std::vector<double>& graded = {}) {
  if (dir.empty()) return;
  std::filesystem::create_directories(dir);
  // series_color(0) (blue) = VIM, series_color(1) (red) = grid, series_color(2) = the graded grid.
  std::vector<std::vector<double>> series = {vim, grid};
  std::vector<std::string> names = {"VIM", "grid"};
  if (!graded.empty() && !std::isnan(graded.front()))
    series.push_back(graded), names.push_back("graded grid");
  const auto info = write_line_plot(std::filesystem::path(dir) / name, nodes, series, names, "nodes",
                                    "relative L2 displacement error vs the voxel reference");
  std::printf("wrote %s/%s (blue = VIM, red = grid, third: graded grid; x axis %s, y axis %s)\n", dir.c_str(),
              name.c_str(), info["x_range"].dump().c_str(), info["y_range"].dump().c_str());
}

}  // namespace

int main(int argc, char** argv) try {
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);  // the AMG solver (Trilinos) needs MPI
  int n = 40, steps = 12;
  std::string scenario_path = "examples/prostate_needle.yaml", plots;
  bool needle = true, compression = true;
  std::vector<long> budgets;
  VimOptions vo;
  std::optional<double> lambda_arg, nu_arg;
  std::string ref_cache;
  unsigned degree = 0;          // --degree; 0 = the scenario's mesh.degree (1 if it has none)
  double sample_spacing = 0.0;  // --sample-spacing: shaft point pitch for every model (0: the scenario's)
  double near_radius = 4.0;     // mm: the "far" error excludes voxel centres this close to the needle path
  double support_stiffness = -1.0, support_spacing = 0.0;  // --support-stiffness / --support-spacing
  double cutting_distance = -1.0;  // --cutting-distance: the needle's cutting distance (mm), all models
  double refine_ratio = -1.0, refine_radius = -1.0;  // --needle-refine / --needle-radius (VIM only)
  double coupling_radius = 0.0;  // --coupling-radius R: the needle bands' radius for every model (0: default)
  std::vector<int> ref_study;    // --ref-study N (repeatable): the needle reference on an N-voxel image too
  std::optional<double>
      min_dihedral_arg;  // --min-dihedral (0 = off); default: the scenario's mesh.min_dihedral
  for (int i = 1; i < argc; ++i) {
    auto value = [&] {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(argv[i]) + " needs a value");
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--n"))
      n = std::atoi(value());
    else if (!std::strcmp(argv[i], "--steps"))
      steps = std::atoi(value());
    else if (!std::strcmp(argv[i], "--scenario"))
      scenario_path = value();
    else if (!std::strcmp(argv[i], "--plots"))
      plots = value();
    else if (!std::strcmp(argv[i], "--skip-needle"))
      needle = false;
    else if (!std::strcmp(argv[i], "--skip-compression"))
      compression = false;
    else if (!std::strcmp(argv[i], "--lambda"))
      lambda_arg = std::atof(value());
    else if (!std::strcmp(argv[i], "--nu"))
      nu_arg = std::atof(value());
    else if (!std::strcmp(argv[i], "--degree"))
      degree = static_cast<unsigned>(std::atoi(value()));
    else if (!std::strcmp(argv[i], "--min-dihedral"))
      min_dihedral_arg = std::atof(value());
    else if (!std::strcmp(argv[i], "--min-rr"))
      vo.min_radius_ratio = std::atof(value());
    else if (!std::strcmp(argv[i], "--max-dihedral"))
      vo.max_dihedral_deg = std::atof(value());
    else if (!std::strcmp(argv[i], "--no-swaps"))
      vo.swaps = false;
    else if (!std::strcmp(argv[i], "--ref-cache"))
      ref_cache = value();
    else if (!std::strcmp(argv[i], "--near-radius"))
      near_radius = std::atof(value());
    else if (!std::strcmp(argv[i], "--shaft"))
      g_shaft = true;
    else if (!std::strcmp(argv[i], "--sample-spacing"))
      sample_spacing = std::atof(value());
    else if (!std::strcmp(argv[i], "--support-stiffness"))
      support_stiffness = std::atof(value());
    else if (!std::strcmp(argv[i], "--support-spacing"))
      support_spacing = std::atof(value());
    else if (!std::strcmp(argv[i], "--cutting-distance"))
      cutting_distance = std::atof(value());
    else if (!std::strcmp(argv[i], "--needle-refine"))
      refine_ratio = std::atof(value());
    else if (!std::strcmp(argv[i], "--needle-radius"))
      refine_radius = std::atof(value());
    else if (!std::strcmp(argv[i], "--ref-study"))
      ref_study.push_back(std::atoi(value()));
    else if (!std::strcmp(argv[i], "--coupling-radius"))
      coupling_radius = std::atof(value());
    else
      budgets.push_back(std::atol(argv[i]));
  }
  if (budgets.empty()) budgets = {125, 343, 1000};

  Scenario sc = read_scenario(scenario_path, 3);
  if (steps > 0)
    for (auto& nd : sc.needles) nd.steps = steps;
  sc.output_every = 0;
  if (nu_arg) sc.poisson_ratio = *nu_arg;
  if (sample_spacing > 0.0)
    for (auto& nd : sc.needles) nd.sample_spacing = sample_spacing;
  if (cutting_distance >= 0.0)
    for (auto& nd : sc.needles) nd.cutting_distance = cutting_distance;
  if (coupling_radius > 0.0)
    for (auto& nd : sc.needles) nd.coupling_radius = coupling_radius;
  if (degree == 0) degree = sc.degree.value_or(1);
  sc.degree = degree;
  if (refine_ratio > 0.0 || refine_radius > 0.0) {  // override (or add) the scenario's needle refinement
    Scenario::NeedleRefinement nr = sc.needle_refinement.value_or(Scenario::NeedleRefinement{1.0, 10.0});
    if (refine_ratio > 0.0) nr.size_ratio = refine_ratio;
    if (refine_radius > 0.0) nr.radius = refine_radius;
    sc.needle_refinement = nr;
  }
  if (refine_ratio == 1.0) sc.needle_refinement.reset();  // --needle-refine 1: off
  // --support-stiffness K (> 0): every fixed volume region becomes an elastic support of stiffness K
  // (with --support-spacing H); 0: back to clamping the nodes in the region.
  for (auto& bc : sc.boundary_conditions) {
    if (bc.type != BoundaryConditionSpec::Type::fixed || bc.region.kind == RegionSpec::Kind::box_face)
      continue;
    if (support_stiffness > 0.0) {
      bc.support = BoundaryConditionSpec::Support::elastic;
      bc.support_stiffness = support_stiffness;
    } else if (support_stiffness == 0.0) {
      bc.support = BoundaryConditionSpec::Support::nodes;
    }
    if (support_spacing > 0.0) bc.support_spacing = support_spacing;
    if (bc.support == BoundaryConditionSpec::Support::elastic)
      std::printf("# %s: elastic support, stiffness %g, spacing %g (0 = region size / 6)\n",
                  bc.region.describe().c_str(), bc.support_stiffness, bc.support_spacing);
  }
  g_scenario = &sc;
  const std::string suffix = degree == 1 ? "" : "_p" + std::to_string(degree);  // plot file names
  // The scenario's mesh.lambda and mesh.min_dihedral as the CLI applies them, with the command line first.
  const MeshOptions scenario_mesh = with_scenario_mesh({}, sc);
  vo.lambda = lambda_arg ? *lambda_arg : scenario_mesh.lambda;
  vo.min_dihedral_deg = min_dihedral_arg ? *min_dihedral_arg : scenario_mesh.min_dihedral_deg;
  const double lambda = vo.lambda;

  const OrientedImage<3> img = phantoms::prostate(n);
  // The anatomy labels behind the phantom: the scenario's needle tissues are label regions.
  const auto labels = std::make_shared<const Image<3>>(phantoms::prostate_labels(n).image);
  const V3 lo = img.image.box_min(), hi = img.image.box_max();
  WorldTransform<3> tf;
  tf.origin = img.origin();
  tf.direction = img.direction;
  check_scenario_geometry<3>(sc, lo, hi, tf);

  // Sample points: every voxel centre (frame), flagged when inside the gland (world ellipsoid at 0).
  Samples s;
  const std::vector<NeedlePath<3>> paths = needle_paths<3>(sc, tf);
  const phantoms::ProstateGeometry g;
  for (std::size_t k = 0; k < img.image.voxel_count(); ++k) {
    const V3 p = img.image.point_of(img.image.index_of(k));
    const V3 w = tf.to_world(p);
    double q = 0;
    for (int a = 0; a < 3; ++a) q += (w[a] / g.gland_semi_axes[a]) * (w[a] / g.gland_semi_axes[a]);
    s.points.push_back(p);
    s.gland.push_back(q <= 1.0);
    if (!paths.empty()) s.far.push_back(paths[0].distance(p) > near_radius);
  }
  long in_gland = 0;
  for (bool b : s.gland) in_gland += b;
  std::printf(
      "# Prostate phantom %ldx%ldx%ld voxels (%.2f mm), %zu sample points (%ld in the gland); nu=%.2f, "
      "lambda=%.2f, VIM min dihedral %g deg (0 = no floor), needle steps=%d\n",
      img.image.size[0], img.image.size[1], img.image.size[2], img.image.spacing[0], s.points.size(),
      in_gland, sc.poisson_ratio, lambda, vo.min_dihedral_deg, sc.needles.empty() ? 0 : sc.needles[0].steps);
  std::fflush(stdout);

  // The scenario's needle refinement (mesh.needle_refinement) shapes the VIM meshes of the needle
  // experiment only; the compression compares the meshes without it (it has no needle path).
  const std::optional<Image<3>> density = needle_refinement_density<3>(sc, img.image, tf);
  auto build = [&](const Image<3>* d, const char* purpose) {
    std::vector<Meshes> out;
    if (d)
      std::printf("# VIM meshes for the %s, with the needle refinement: size ratio %.3g, radius %.3g mm\n",
                  purpose, sc.needle_refinement->size_ratio, sc.needle_refinement->radius);
    else
      std::printf("# VIM meshes for the %s, without a needle refinement\n", purpose);
    for (long b : budgets) {
      out.push_back(make_meshes(img, b, vo, d, sc, tf, labels));
      std::printf("mesh budget %ld: %zu nodes, grid %zu cells, VIM %zu cells (%.1f s)\n", b, out.back().nodes,
                  out.back().cells_grid, out.back().cells_vim, out.back().vim_seconds);
      describe("grid", out.back().grid);
      describe("VIM ", out.back().vim);
      if (out.back().graded) describe("graded grid", *out.back().graded);
      std::fflush(stdout);
    }
    return out;
  };
  const bool needle_plain = needle && !density;  // the needle experiment on meshes without a refinement
  const char* plain_purpose = !compression   ? "needle"
                              : needle_plain ? "compression and the needle"
                                             : "compression";
  const std::vector<Meshes> plain =
      compression || needle_plain ? build(nullptr, plain_purpose) : std::vector<Meshes>{};
  const std::vector<Meshes> refined = needle && density ? build(&*density, "needle") : std::vector<Meshes>{};
  const std::vector<Meshes>& needle_meshes = density ? refined : plain;
  std::vector<double> xs;  // node counts (the same for both sets: one budget, one grid)
  for (const auto& m : compression ? plain : needle_meshes) xs.push_back(static_cast<double>(m.nodes));

  if (compression) {
    // Reference: the voxel model with the scenario's moduli.
    std::vector<double> e(img.image.data.begin(), img.image.data.end());
    auto t = Clock::now();
    std::vector<V3> ref(s.points.size());
    double w0 = 0;
    unsigned ref_dofs = 0;
    // --ref-cache FILE: reuse the reference displacement of an earlier run with the same image and ν.
    std::ifstream in(ref_cache, std::ios::binary);
    const std::string key =
        std::to_string(n) + " " + std::to_string(sc.poisson_ratio) + " " + std::to_string(ref.size());
    std::string cached_key;
    if (!ref_cache.empty() && in && std::getline(in, cached_key) && cached_key == key) {
      in.read(reinterpret_cast<char*>(&w0), sizeof w0);
      in.read(reinterpret_cast<char*>(&ref_dofs), sizeof ref_dofs);
      in.read(reinterpret_cast<char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(V3)));
      std::printf("\n(reference read from %s)", ref_cache.c_str());
    } else {
      auto ref_model =
          fem::ElasticModel<3>::voxel_grid(img.image.size, lo, hi, scenario_modulus(sc, e), sc.poisson_ratio);
      add_compression(ref_model, lo, hi);
      w0 = ref_model.solve().strain_energy;
      ref = ref_model.sample(s.points);
      ref_dofs = ref_model.n_dofs();
      if (!ref_cache.empty()) {
        std::ofstream out(ref_cache, std::ios::binary);
        out << key << "\n";
        out.write(reinterpret_cast<const char*>(&w0), sizeof w0);
        out.write(reinterpret_cast<const char*>(&ref_dofs), sizeof ref_dofs);
        out.write(reinterpret_cast<const char*>(ref.data()),
                  static_cast<std::streamsize>(ref.size() * sizeof(V3)));
      }
    }
    std::printf(
        "\n## Prostate compression (x_max clamped, x_min pushed +%.0f%% along x): reference %u DoFs, %.1f "
        "s\n",
        100 * kStrain, ref_dofs, since(t));
    std::printf(
        "| nodes | cells grid | cells VIM | relL2 grid | relL2 VIM | VIM/grid | relL2 gland grid | relL2 "
        "gland VIM | "
        "max/|u|max grid | max/|u|max VIM | energy err grid | energy err VIM |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    std::vector<double> yv, yg;
    for (const auto& m : plain) {
      double wg = 0, wv = 0;
      const Err eg = compare(solve_compression(m.grid, sc, lo, hi, s, &wg, degree), ref, s);
      const Err ev = compare(solve_compression(m.vim, sc, lo, hi, s, &wv, degree), ref, s);
      std::printf("| %zu | %zu | %zu | %.4f | %.4f | **%.3f** | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n",
                  m.nodes, m.cells_grid, m.cells_vim, eg.rel_all, ev.rel_all, ev.rel_all / eg.rel_all,
                  eg.rel_gland, ev.rel_gland, eg.max_rel, ev.max_rel, std::abs(wg - w0) / w0,
                  std::abs(wv - w0) / w0);
      std::fflush(stdout);
      yv.push_back(ev.rel_all), yg.push_back(eg.rel_all);
    }
    plot(plots, "validation_prostate_compression" + suffix + ".png", xs, yv, yg);
  }

  if (needle) {
    SimulationOptions opt;
    opt.progress = false;
    auto t = Clock::now();
    auto ref_sim = NeedleSimulation<3>::voxel(img.image, tf, sc, opt, labels);
    const NeedleOut ref = finish(ref_sim, s);
    std::printf(
        "\n## Prostate needle insertion (%s, %d steps, %.1f mm): reference %u DoFs, %d shaft points, "
        "axial force %.2f mN, %.1f s\n",
        scenario_path.c_str(), sc.needles[0].steps, sc.needles[0].depth, ref_sim.model().n_dofs(),
        ref.shaft_points, ref.axial_force, since(t));
    std::printf("reference target displacement |u| (mm):");
    for (std::size_t k = 0; k < sc.targets.size(); ++k)
      std::printf(" %s %.4f", sc.targets[k].name.c_str(), ref.targets[k].norm());
    std::printf("(relL2 far: voxel centres more than %.1f mm from the needle path)\n", near_radius);
    for (int nr : ref_study) reference_on_other_image(nr, sc, opt, s, tf, ref);
    std::printf(
        "\n| nodes | mesh | shaft pts | relL2 | relL2 gland | relL2 far | max/|u|max | axial force mN |");
    for (const auto& tg : sc.targets) std::printf(" err %s mm |", tg.name.c_str());
    std::printf(
        " VIM/grid relL2 | VIM/grid far | VIM/graded relL2 | VIM/graded far "
        "|\n|---|---|---|---|---|---|---|---|");
    for (std::size_t k = 0; k < sc.targets.size(); ++k) std::printf("---|");
    std::printf("---|---|---|---|\n");
    std::vector<double> yv, yg, yd;
    for (const auto& m : needle_meshes) {
      const ModelRow grid = needle_row("grid", m.nodes, m.grid, sc, opt, s, ref, {});
      const ModelRow graded =
          m.graded ? needle_row("graded grid", m.nodes, *m.graded, sc, opt, s, ref, {}) : ModelRow{};
      needle_row("VIM", m.nodes, m.vim, sc, opt, s, ref, {grid, graded});
      yg.push_back(grid.rel), yd.push_back(graded.rel), yv.push_back(rows_vim);
    }
    plot(plots, "validation_prostate_needle" + suffix + ".png", xs, yv, yg, yd);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "validate_needle: %s\n", e.what());
  return 1;
}

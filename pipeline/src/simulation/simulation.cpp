// Needle-insertion simulation (simulation.hpp): the scenario's model in the image frame — per-cell
// modulus (Eq. 15), boundary conditions with world regions mapped to the frame, elastic supports —
// built once; then each needle of the scenario is inserted by NeedleInsertion (needle_insertion.hpp),
// re-sampled where its shaft points turn out dependent, and checked for results not to take at face
// value. The needle models are described in simulation.hpp.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <vim/fem/distributed.hpp>
#include <vim/pipeline/output/vtk_output.hpp>
#include <vim/pipeline/scenario/scenario_regions.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

#include "simulation/largest_strain.hpp"
#include "simulation/needle_compare_linear.hpp"
#include "simulation/needle_insertion.hpp"
#include "simulation/needle_options.hpp"
#include "simulation/probe_motion.hpp"
#include "simulation/procedure_dose.hpp"
#include "simulation/simulation_context.hpp"
#include "simulation/simulation_output.hpp"
#include "simulation/solve_comm.hpp"
#include "simulation/static_load.hpp"

namespace vim::pipeline {

using json = nlohmann::json;

template <int dim>
struct NeedleSimulation<dim>::Impl : SimulationContext<dim> {
  using Base = SimulationContext<dim>;
  using Base::blocked, Base::held_regions, Base::box_max, Base::box_min, Base::locator, Base::model,
      Base::opt, Base::point_axes, Base::region, Base::sc, Base::solver, Base::tf;
  void setup(const std::vector<Vec>& vertices);
  void setup_probe();
  fem::VolumeSupport<dim> volume_support(const BoundaryConditionSpec& bc, const std::string& where) const;
  NeedleOutcome<dim> run_needle(const NeedleSpec& spec, const std::string& prefix,
                                bool snap_to_vertices = false) {
    auto insertion = std::make_unique<NeedleInsertion<dim>>(*this, spec, prefix, snap_to_vertices);
    NeedleOutcome<dim> out = insertion->run();
    if (spec.withdrawn_later()) left_in[spec.name] = std::move(insertion);
    return out;
  }
  // The needles left in that a later action withdraws, by name, until then.
  std::map<std::string, std::unique_ptr<NeedleInsertion<dim>>> left_in;
  void actions_after(std::size_t insertions, ProbeMotions<dim>& probe, SimulationResult<dim>& res,
                     json& needles);
  std::vector<std::string> held_path_warnings(const NeedleSpec& spec) const;
  // --compare-linear: the needle on the other material model, nothing written.
  NeedleOutcome<dim> insert_with_other_model(const NeedleSpec& spec, const std::string& prefix) {
    const Scenario::MaterialModel own = sc.material_model;
    const SimulationOptions saved = opt;
    sc.material_model = own == Scenario::MaterialModel::neo_hookean ? Scenario::MaterialModel::linear
                                                                    : Scenario::MaterialModel::neo_hookean;
    opt.output_file = nullptr, opt.piece_file = nullptr, opt.progress = false;
    std::vector<std::string> ignored;
    try {
      NeedleOutcome<dim> out = insert_needle(spec, prefix, ignored);
      sc.material_model = own, opt = saved;
      return out;
    } catch (...) {
      sc.material_model = own, opt = saved;
      throw;
    }
  }
  NeedleOutcome<dim> insert_needle(const NeedleSpec& spec, const std::string& prefix,
                                   std::vector<std::string>& warnings);
  void check_axial_force(const NeedleSpec& spec, NeedleOutcome<dim>& needle,
                         std::vector<std::string>& warnings) const;
  void check_sample_spacing(const NeedleSpec& spec, const std::string& who,
                            std::vector<std::string>& warnings) const;
};

template <int dim>
fem::Region<dim> SimulationContext<dim>::region(const RegionSpec& r) const {
  return scenario_region<dim>(r, box_min, box_max, tf, label_image.get());
}

// Elastic support of a volume region: a lattice of pitch h anchored at the region (its centre; a box's
// lower corner), points at anchor + (i + ½)·h along the world axes, kept when inside the region and
// inside the model's box; weight h^dim each. The lattice depends only on the region, the pitch and the
// box, so every mesh of the same image (and the voxel reference) gets the same points.
template <int dim>
fem::VolumeSupport<dim> NeedleSimulation<dim>::Impl::volume_support(const BoundaryConditionSpec& bc,
                                                                    const std::string& where) const {
  const RegionSpec& r = bc.region;
  Vec anchor, lo, hi;
  double size = 0.0;
  // World bounding box of the model's box.
  lo = hi = tf.to_world(box_min);
  for (int corner = 0; corner < (1 << dim); ++corner) {
    Vec x;
    for (int d = 0; d < dim; ++d) x[d] = (corner >> d) & 1 ? box_max[d] : box_min[d];
    const Vec w = tf.to_world(x);
    lo = lo.cwiseMin(w), hi = hi.cwiseMax(w);
  }
  if (r.kind == RegionSpec::Kind::box) {
    anchor = spec_vector<dim>(r.lo);
    lo = lo.cwiseMax(spec_vector<dim>(r.lo)), hi = hi.cwiseMin(spec_vector<dim>(r.hi));
    size = (spec_vector<dim>(r.hi) - spec_vector<dim>(r.lo)).minCoeff();
  } else {
    anchor = spec_vector<dim>(r.center);
    size = r.radius;
    if (r.kind == RegionSpec::Kind::sphere)
      lo = lo.cwiseMax((anchor.array() - r.radius).matrix()),
      hi = hi.cwiseMin((anchor.array() + r.radius).matrix());
  }
  const double h = bc.support_spacing > 0.0 ? bc.support_spacing : size / 6.0;
  if (!(h > 0.0)) throw ScenarioError(where + ": the region has no extent for an elastic support");
  std::array<long, dim> i0, i1;
  double count = 1.0;
  for (int d = 0; d < dim; ++d) {
    i0[d] = static_cast<long>(std::floor((lo[d] - anchor[d]) / h - 0.5));
    i1[d] = static_cast<long>(std::ceil((hi[d] - anchor[d]) / h - 0.5));
    count *= std::max(0L, i1[d] - i0[d] + 1);
  }
  if (count > 5e7)
    throw ScenarioError(where + ": the elastic support's spacing " + std::to_string(h) +
                        " gives too many sample points; "
                        "set a larger support.elastic.spacing");
  const fem::Region<dim> reg = region(r);
  fem::VolumeSupport<dim> sup;
  sup.name = r.describe();
  sup.stiffness = bc.support_stiffness;
  const double weight = std::pow(h, dim);
  const double tol = 1e-9 * (box_max - box_min).norm();
  std::array<long, dim> i = i0;
  while (true) {
    Vec w;
    for (int d = 0; d < dim; ++d) w[d] = anchor[d] + (static_cast<double>(i[d]) + 0.5) * h;
    const Vec x = tf.to_frame(w);
    bool in = reg.contains(x);
    for (int d = 0; d < dim && in; ++d) in = x[d] >= box_min[d] - tol && x[d] <= box_max[d] + tol;
    if (in) {
      sup.points.push_back(x);
      sup.weights.push_back(weight);
    }
    int d = 0;
    while (d < dim && ++i[d] > i1[d]) i[d] = i0[d], ++d;
    if (d == dim) break;
  }
  if (sup.points.empty())
    throw ScenarioError(where + ": region " + r.describe() +
                        " holds no sample point of the elastic support inside the image box");
  return sup;
}

template <int dim>
void NeedleSimulation<dim>::Impl::setup(const std::vector<Vec>& vertices) {
  // Geometry checks against the model's box (the image box), then the boundary conditions.
  if (!opt.scenario_checked) check_scenario_geometry<dim>(sc, box_min, box_max, tf);
  solver.type = sc.solver_type == "direct" ? fem::SolverOptions::Type::direct
                : sc.solver_type == "amg"  ? fem::SolverOptions::Type::amg
                                           : fem::SolverOptions::Type::automatic;
  solver.tolerance = sc.solver_tolerance;
  solver.max_memory = opt.max_memory;
  // A 3D needle's precomputation needs one column K⁻¹cᵀ per coupling row (three per station, tens to
  // hundreds): CHOLMOD's factorisation and one back-substitution per block of 32 rows beat one CG solve
  // per row well beyond the single-solve limit (docs/performance.md, "Needle steps": 225k P2 DoFs
  // factorised and 42 rows precomputed in 3.9 GB).
  if (dim == 3 && !sc.needles.empty()) solver.direct_limit = kNeedleDirectLimit3D;
  blocked.assign(vertices.size(), false);
  for (std::size_t i = 0; i < sc.boundary_conditions.size(); ++i) {
    const auto& bc = sc.boundary_conditions[i];
    const std::string where = sc.where(bc.line) + "boundary_conditions[" + std::to_string(i) + "]";
    if (bc.support == BoundaryConditionSpec::Support::elastic) {
      model->add_volume_support(volume_support(bc, where));
      held_regions.push_back(region(bc.region));
      continue;
    }
    const fem::Region<dim> reg = region(bc.region);
    std::size_t hits = 0;
    for (const auto& v : vertices) hits += reg.contains(v) ? 1 : 0;
    if (hits == 0)
      throw ScenarioError(
          where + ": region " + bc.region.describe() +
          " selects no mesh node (regions are in world coordinates; box faces name the image box)");
    if (bc.is_dirichlet()) {
      fem::DirichletBC<dim> d;
      d.region = reg;
      const bool all = std::all_of(bc.components.begin(), bc.components.end(), [](bool b) { return b; });
      if (bc.type == BoundaryConditionSpec::Type::displacement)
        d.value = tf.vector_to_frame(spec_vector<dim>(bc.value));
      if (!all && tf.axis_aligned()) {
        // Every image axis is a world axis: the world components are frame components.
        for (int c = 0; c < dim; ++c) d.components[c] = bc.components[tf.world_axis_of(c)];
      } else if (!all) {
        // An oblique image: the world axes seen from the frame (columns of Dᵀ), values in world components.
        d.axes = tf.direction.transpose();
        point_axes = d.axes;
        for (int c = 0; c < dim; ++c) d.components[c] = bc.components[c];
        if (bc.type == BoundaryConditionSpec::Type::displacement) d.value = spec_vector<dim>(bc.value);
      }
      model->add_dirichlet(d);
      if (all) {
        for (std::size_t v = 0; v < vertices.size(); ++v)
          blocked[v] = blocked[v] || reg.contains(vertices[v]);
        held_regions.push_back(reg);
      }
    } else {
      fem::SurfaceLoad<dim> load;
      load.region = reg;
      if (bc.type == BoundaryConditionSpec::Type::pressure)
        load.pressure = bc.value[0];
      else
        load.traction = tf.vector_to_frame(spec_vector<dim>(bc.value));
      model->add_surface_load(load);
    }
  }
  if (sc.probe) setup_probe();
  for (const auto& t : sc.targets)
    if (locator().locate(tf.to_frame(spec_vector<dim>(t.position))) < 0)
      throw ScenarioError(sc.where(t.line) + "target '" + t.name + "' is outside the meshed domain");
}

// The probe's foundation: a volume support like a condition's (its lattice over the cylinder), the model's
// support after the conditions' elastic ones.
template <int dim>
void NeedleSimulation<dim>::Impl::setup_probe() {
  const ProbeSpec& spec = *sc.probe;
  const std::string where = sc.where(spec.line) + "probe";
  if (opt.mpi_ranks > 1)
    throw ScenarioError(where +
                        ": the probe's elastic foundation is solved on one process; run without "
                        "--mpi-ranks");
  if (opt.compare_linear && !spec.motions.empty())
    throw ScenarioError(where +
                        ": --compare-linear with a probe motion is not built (the neo-Hookean model "
                        "has no moving foundation base); leave out --compare-linear");
  if (voxel && sc.solver_type == "multigrid")
    throw ScenarioError(where + ": the probe's elastic foundation needs solver.type auto, direct or amg");
  const fem::VolumeSupport<dim> sup = volume_support(spec.hold, where);
  typename Base::Probe p;
  p.support = static_cast<std::size_t>(std::count_if(
      sc.boundary_conditions.begin(), sc.boundary_conditions.end(),
      [](const BoundaryConditionSpec& bc) { return bc.support == BoundaryConditionSpec::Support::elastic; }));
  p.points = sup.points;
  p.weights = sup.weights;
  p.stiffness = sup.stiffness;
  p.center = spec_vector<dim>(spec.hold.region.center);
  p.axis = spec_vector<dim>(spec.hold.region.axis_vector).normalized();
  model->add_volume_support(sup);
  held_regions.push_back(region(spec.hold.region));
  this->probe = std::move(p);
}

template <int dim>
NeedleSimulation<dim>::NeedleSimulation() : impl_(std::make_unique<Impl>()) {}
template <int dim>
NeedleSimulation<dim>::~NeedleSimulation() = default;
template <int dim>
NeedleSimulation<dim>::NeedleSimulation(NeedleSimulation&&) noexcept = default;

template <int dim>
NeedleSimulation<dim>::NeedleSimulation(const MeshModel<dim>& mm, const Scenario& scenario,
                                        SimulationOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  m.sc = scenario;
  m.opt = std::move(options);
  m.tf = mm.transform;
  m.label_image = mm.label_image;
  if (scenario.dim != dim)
    throw ScenarioError(scenario.where(0) + "scenario was parsed for a " + std::to_string(scenario.dim) +
                        "D image");
  if (mm.mesh.n_cells() == 0) throw std::invalid_argument("needle simulation: the mesh has no cells");
  if (scenario.modulus_from_image && mm.values.size() != mm.mesh.n_cells())
    throw std::invalid_argument("needle simulation: the mesh has no per-element values (voxel means)");
  std::vector<double> mean(mm.mesh.n_cells(), 0.0);
  if (scenario.modulus_from_image)
    for (std::size_t c = 0; c < mean.size(); ++c) mean[c] = mm.values[c].mean;
  m.E = scenario_modulus(scenario, mean);
  // --labels: a label with a modulus of its own gives it to its elements (docs/labels.md).
  for (std::size_t c = 0; c < mm.label.size(); ++c)
    if (const auto it = mm.label_modulus.find(mm.label[c]); it != mm.label_modulus.end()) m.E[c] = it->second;
  m.degree = m.opt.degree ? *m.opt.degree : scenario.degree ? *scenario.degree : 1u;
  m.box_min = mm.mesh.points[0];
  m.box_max = mm.mesh.points[0];
  for (const auto& p : mm.mesh.points) {
    m.box_min = m.box_min.cwiseMin(p);
    m.box_max = m.box_max.cwiseMax(p);
  }
  if (scenario.solver_type == "multigrid")
    throw ScenarioError(
        scenario.where(0) +
        "solver.type multigrid is for the voxel model (--mesher voxel); use auto, direct or amg");
  m.model.emplace(mm.mesh, m.E, scenario.poisson_ratio, m.degree);
  if (m.opt.mpi_ranks > 1) fem::distribute_solves(*m.model, solve_comm(m.opt));
  m.grid = m.opt.world_grid ? m.opt.world_grid
                            : std::make_shared<const UnstructuredGrid>(simplex_grid(mm.mesh, mm.transform));
  // P2: quadratic cells carry the mid-edge values (edges), so ParaView interpolates quadratically.
  if (m.degree == 2)
    m.grid = std::make_shared<const UnstructuredGrid>(quadratic_simplex_grid<dim>(*m.grid, &m.edges));
  m.setup(m.model->vertices());
  m.build_seconds = seconds_since(t0);
}

template <int dim>
NeedleSimulation<dim> NeedleSimulation<dim>::voxel(const Image<dim>& image,
                                                   const WorldTransform<dim>& transform,
                                                   const Scenario& scenario, SimulationOptions options,
                                                   std::shared_ptr<const Image<dim>> labels) {
  NeedleSimulation sim;
  Impl& m = *sim.impl_;
  const auto t0 = Clock::now();
  m.sc = scenario;
  m.opt = std::move(options);
  m.tf = transform;
  m.voxel = true;
  if (labels && labels->size != image.size)
    throw std::invalid_argument("voxel model: the label image is not on the modulus image's grid");
  m.label_image = std::move(labels);
  if (scenario.dim != dim)
    throw ScenarioError(scenario.where(0) + "scenario was parsed for a " + std::to_string(scenario.dim) +
                        "D image");
  if (!m.opt.scenario_checked) check_modulus_image(scenario, image);
  std::vector<double> values(image.data.begin(), image.data.end());
  m.E = scenario_modulus(scenario, values);
  m.box_min = image.box_min();
  m.box_max = image.box_max();
  m.model.emplace(
      fem::ElasticModel<dim>::voxel_grid(image.size, m.box_min, m.box_max, m.E, scenario.poisson_ratio));
  // multigrid: the p4est grid with its matrix-free multigrid, on one rank too
  if (m.opt.mpi_ranks > 1 || scenario.solver_type == "multigrid")
    fem::distribute_solves(*m.model, solve_comm(m.opt));
  const auto& verts = m.model->vertices();
  // One hexahedron (quad) per voxel on the lattice of corners, which is the model's vertex numbering.
  m.grid = m.opt.world_grid ? m.opt.world_grid
                            : std::make_shared<const UnstructuredGrid>(voxel_grid(image, transform));
  if (m.grid->points.size() != verts.size())
    throw std::logic_error("voxel model: the world grid does not have the model's vertices");
  m.setup(verts);
  m.build_seconds = seconds_since(t0);
  return sim;
}

template <int dim>
const std::vector<double>& NeedleSimulation<dim>::youngs_modulus() const {
  return impl_->E;
}
template <int dim>
fem::ElasticModel<dim>& NeedleSimulation<dim>::model() {
  return *impl_->model;
}

// The needle's path through held tissue (a fixed or displacement condition, nodes or elastic support):
// the tissue there cannot follow the needle, so the forces grow with the held length, far beyond those
// of free tissue. Legitimate (a needle into a clamp) but rarely meant: one warning per condition crossed,
// with the held length of the path, measured at 1/1000 of the depth.
template <int dim>
std::vector<std::string> NeedleSimulation<dim>::Impl::held_path_warnings(const NeedleSpec& spec) const {
  std::vector<std::string> out;
  const needle::NeedlePath<dim> path = needle_path<dim>(spec, tf);
  const int samples = 1000;
  for (std::size_t i = 0; i < sc.boundary_conditions.size(); ++i) {
    const auto& bc = sc.boundary_conditions[i];
    if (!bc.is_dirichlet()) continue;
    const fem::Region<dim> reg = region(bc.region);
    int inside = 0;
    for (int k = 0; k <= samples; ++k)
      inside += reg.contains(path.entry + (spec.depth * k / samples) * path.axis) ? 1 : 0;
    if (inside == 0) continue;
    std::ostringstream w;
    w << sc.where(bc.line) << (spec.name.empty() ? std::string("the needle") : "needle '" + spec.name + "'");
    if (bc.region.kind == RegionSpec::Kind::box_face)
      w << " touches the held face " << bc.region.describe() << " of boundary_conditions[" << i << "]"
        << (inside > 1                 ? " along its path"
            : reg.contains(path.entry) ? " at its entry"
                                       : " at the end of its path");
    else
      w << " runs through the held region " << bc.region.describe() << " of boundary_conditions[" << i
        << "] over about " << std::setprecision(2) << spec.depth * inside / samples << std::setprecision(6)
        << " " << sc.length_unit << " of its " << spec.depth << " " << sc.length_unit << " path";
    w << ": tissue held there cannot follow the needle, so its forces are far larger than in free tissue";
    out.push_back(w.str());
  }
  return out;
}

// The actions of a procedure that come after its first `insertions` insertions (before the next one, or
// at the end), in the procedure's order: the probe's motions and the withdrawals of needles left in (their
// runs in res.needles and their report entries grow by the withdrawal's steps).
template <int dim>
void NeedleSimulation<dim>::Impl::actions_after(std::size_t insertions, ProbeMotions<dim>& probe,
                                                SimulationResult<dim>& res, json& needles) {
  struct Action {
    int number;  // in the procedure
    const ProbeMotionSpec* motion;
    const NeedleSpec* withdrawn;
  };
  std::vector<Action> actions;
  if (sc.probe)
    for (const ProbeMotionSpec& motion : sc.probe->motions)
      if (motion.after == insertions) actions.push_back({motion.action, &motion, nullptr});
  for (const NeedleSpec& spec : sc.needles)
    if (spec.withdrawn_later() && spec.withdraw_after == insertions)
      actions.push_back({spec.withdraw_action, nullptr, &spec});
  std::sort(actions.begin(), actions.end(),
            [](const Action& a, const Action& b) { return a.number < b.number; });
  for (const Action& action : actions) {
    if (action.motion) {
      probe.move(*action.motion, res);
      continue;
    }
    const NeedleSpec& spec = *action.withdrawn;
    std::size_t r = 0;
    while (r < res.needles.size() && res.needles[r].name != spec.name) ++r;
    NeedleOutcome<dim> out = left_in.at(spec.name)->withdraw_later(res.needles, r);
    res.needles[r] = std::move(out.run);
    needles[r] = std::move(out.report);
    left_in.erase(spec.name);
  }
}

// Inserts one needle; where its shaft points turn out nearly dependent (a path along mesh edges or
// through a row of vertices), runs it again with the shaft at the mesh vertices and, for the default
// spacing, with a coarser one, saying so in `warnings`. Solver failures become ScenarioErrors naming
// the scenario's line.
template <int dim>
NeedleOutcome<dim> NeedleSimulation<dim>::Impl::insert_needle(const NeedleSpec& spec,
                                                              const std::string& prefix,
                                                              std::vector<std::string>& warnings) {
  const std::string who = spec.name.empty() ? std::string("the needle") : "needle '" + spec.name + "'";
  const double edge = locator().mean_edge_length();
  try {
    try {
      return run_needle(spec, prefix);
    } catch (const fem::DependentPointConstraints& e) {
      // Shaft points inside a chain of collinear mesh edges (a path along a box edge or a grid line):
      // run again with the points on those edges moved to the edges' vertices (sample_shaft).
      std::ostringstream w;
      w << sc.where(spec.line) << who << ": its shaft points along mesh edges were nearly dependent ("
        << e.what() << "); ran it again with the shaft sampled at the mesh vertices on its path";
      try {
        NeedleOutcome<dim> needle = run_needle(spec, prefix, true);
        warnings.push_back(w.str());
        needle.report["shaft_sampled_at_vertices"] = true;
        return needle;
      } catch (const fem::DependentPointConstraints&) {
        // Still dependent: e.g. a path through cells that meet at single vertices (parallel to the
        // diagonals of a grid, about halfway between them), where one point per cell at the default
        // spacing (half the mean edge) made the constraints conflict. With the default spacing, try
        // one and two mean element edges; an explicit sample_spacing is the user's choice (the
        // error below suggests a value).
        if (spec.sample_spacing > 0.0) throw;
        NeedleSpec coarser = spec;
        std::optional<NeedleOutcome<dim>> run;
        for (const double factor : {1.0, 2.0}) {
          coarser.sample_spacing = factor * edge;
          try {
            run = run_needle(coarser, prefix, true);
          } catch (const fem::DependentPointConstraints&) {
            if (factor == 2.0) throw;
            continue;
          }
          break;
        }
        if (!run) throw;
        std::ostringstream c;
        c << sc.where(spec.line) << who << ": its shaft points at the default spacing (" << 0.5 * edge
          << ", half the mean element edge) were nearly dependent (" << e.what() << "); ran it again with "
          << "sample_spacing = " << coarser.sample_spacing << " and the shaft at the mesh vertices where it "
          << "runs along edges";
        warnings.push_back(c.str());
        run->report["shaft_sampled_at_vertices"] = true;
        run->report["shaft_pitch_increased_from"] = 0.5 * edge;
        return std::move(*run);
      }
    }
  } catch (const fem::SingularConstraints& e) {  // the first solve: name the scenario's conditions
    const int line = sc.boundary_conditions.empty() ? 0 : sc.boundary_conditions.front().line;
    throw ScenarioError(sc.where(line) + "boundary_conditions: " + e.what());
  } catch (const fem::DependentPointConstraints& e) {
    // Shaft points closer together than the elements resolve: a path along element edges or through a
    // row of vertices, or a sample_spacing below the element size.
    std::ostringstream s;
    s << sc.where(spec.line) << who << ": its embedded shaft points constrain nearly the same displacements ("
      << e.what()
      << "); this happens where shaft points are closer together than the elements can resolve: a path "
      << "along element edges or through a row of mesh vertices";
    if (spec.sample_spacing > 0.0 && spec.sample_spacing < edge)
      s << ", or needle.sample_spacing = " << spec.sample_spacing << " below the mean element edge (" << edge
        << ")";
    s << "; set needle.sample_spacing to about the mean element edge (" << edge
      << ") or more (the default is half of it), or move the path slightly";
    throw ScenarioError(s.str());
  }
  throw std::logic_error("insert_needle: unreachable");
}

// Under a law whose axial force never falls (a stuck shaft pushing into linear elastic tissue), a force
// that is negative or falls means the discretisation holds the tissue at the tip back (a shaft point
// joins at rest, and P1 spreads that over its whole element): a warning with the remedies.
template <int dim>
void NeedleSimulation<dim>::Impl::check_axial_force(const NeedleSpec& spec, NeedleOutcome<dim>& needle,
                                                    std::vector<std::string>& warnings) const {
  const std::string who = spec.name.empty() ? std::string("the needle") : "needle '" + spec.name + "'";
  const double edge = locator().mean_edge_length();
  const std::vector<double>& f = needle.run.axial_force;
  double largest = 0.0;
  std::vector<int> dips;
  // The insertion's steps (on the way out the force falls and reverses).
  const std::size_t n = std::min(f.size(), static_cast<std::size_t>(spec.steps) + 1);
  for (std::size_t k = 1; k < n; ++k) {
    largest = std::max(largest, std::abs(f[k]));
    if (f[k] < 0.0 || f[k] < f[k - 1] - 0.05 * largest) dips.push_back(static_cast<int>(k));
  }
  if (!dips.empty()) {
    const std::size_t k = static_cast<std::size_t>(dips.front());
    std::ostringstream w;
    w << sc.where(spec.line) << who << ": the axial force is negative or falls at " << dips.size() << " of "
      << n - 1 << " steps (first: step " << k << ", " << f[k - 1] << " -> " << f[k]
      << "), which a stuck needle pushing into elastic tissue does not do: the shaft points that join at the "
         "tip "
      << "hold the tissue there at rest, and "
      << (this->voxel || this->degree == 1 ? "linear elements spread that over"
                                           : "the elements spread that over")
      << " their whole size; " << (this->voxel || this->degree == 1 ? "use mesh.degree: 2, " : "")
      << "refine along the path (mesh.needle_refinement, more nodes) or set needle.sample_spacing to about "
         "the "
      << "mean element edge (" << edge << ")";
    warnings.push_back(w.str());
    needle.report["axial_force_dips"] = dips;
  }
}

// A sample spacing below half the mean edge of a linear element: a warning.
template <int dim>
void NeedleSimulation<dim>::Impl::check_sample_spacing(const NeedleSpec& spec, const std::string& who,
                                                       std::vector<std::string>& warnings) const {
  const double edge = locator().mean_edge_length();
  if ((this->voxel || this->degree == 1) && spec.sample_spacing > 0.0 && spec.sample_spacing < 0.5 * edge) {
    // Several joined points per linear element impose the linear field of their displacements on
    // the whole element, also beyond the tip (a probe: 1 mm spacing on 6 mm tetrahedra moved the tissue
    // 3 mm ahead of the tip 2.5 mm backwards, and the axial force went negative).
    std::ostringstream w;
    w << sc.where(spec.line) << who << ": needle.sample_spacing = " << spec.sample_spacing
      << " is below half the mean element edge (" << edge << "): linear elements impose the displacements of "
      << "the shaft points in one element on all of it, also ahead of the tip, so the tissue there can be "
         "pulled "
      << "back and the forces can drop or change sign; leave sample_spacing out (half the mean edge) or "
         "use degree 2";
    warnings.push_back(w.str());
  }
}

// A needle whose stick-slip active set still changed after the last sweep at some steps.
template <int dim>
std::string unsettled_warning(const NeedleRun<dim>& r, int max_sweeps) {
  std::ostringstream w;
  w << (r.name.empty() ? std::string("the needle") : "needle '" + r.name + "'") << ": at "
    << r.unsettled_steps.size() << " of " << r.depth.size() - 1 << " steps (first: step "
    << r.unsettled_steps.front() << ") the stick-slip active set still changed after " << max_sweeps
    << (max_sweeps > 1 ? " sweeps" : " sweep")
    << "; those steps keep the last iterate, so a shaft load may exceed its friction limit (try more steps)";
  return w.str();
}

template <int dim>
SimulationResult<dim> NeedleSimulation<dim>::run() {
  Impl& m = *impl_;
  SimulationResult<dim> res;
  json& rep = res.report;
  rep["scenario"] = {{"file", m.sc.source}, {"yaml", m.sc.text}};
  rep["units"] = {{"length", m.sc.length_unit}, {"modulus", m.sc.modulus_unit}};
  for (const auto& t : m.sc.targets) {
    res.target_names.push_back(t.name);
    res.target_positions.push_back(spec_vector<dim>(t.position));
    rep["target_positions"][t.name] = t.position;  // world (a label target's centroid, docs/labels.md)
  }
  rep["model"] = model_report<dim>(m);
  rep["boundary_conditions"] = m.sc.boundary_conditions.size();
  json needles = json::array(), compared = json::array();
  const bool finite_strain = m.sc.material_model == Scenario::MaterialModel::neo_hookean;
  if ((finite_strain || m.opt.compare_linear) && !m.sc.needles.empty() && m.opt.mpi_ranks > 1)
    throw ScenarioError(m.sc.where(m.sc.material_model_line) +
                        "material.model = 'neo-hookean' is solved on one process; run without --mpi-ranks");
  ProbeMotions<dim> probe(m);
  for (const auto& spec : m.sc.needles) {
    m.actions_after(res.needles.size(), probe, res, needles);
    const std::string prefix = m.sc.needle_list ? spec.name + "/" : "";
    const std::string who = spec.name.empty() ? std::string("the needle") : "needle '" + spec.name + "'";
    m.check_sample_spacing(spec, who, res.warnings);
    std::optional<NeedleOutcome<dim>> other;
    if (m.opt.compare_linear) other = m.insert_with_other_model(spec, prefix);
    NeedleOutcome<dim> needle = m.insert_needle(spec, prefix, res.warnings);
    if (other)
      compared.push_back(finite_strain ? compare_needle_runs<dim>(other->run, needle.run, res.target_names)
                                       : compare_needle_runs<dim>(needle.run, other->run, res.target_names));
    // A finite-strain run has no small-strain warning (its mesh strain is Green–Lagrange's).
    const std::string strain = finite_strain
                                   ? std::string()
                                   : small_strain_warning(m.sc.where(spec.line), who, needle.run.mesh_strain);
    if (!strain.empty()) res.warnings.push_back(strain);
    for (auto& w : needle.warnings) res.warnings.push_back(std::move(w));
    std::vector<std::string> target_names;
    for (const auto& t : m.sc.targets) target_names.push_back(t.name);
    const std::string near = near_field_warning(m.sc.where(spec.line), who, needle.run.small_strain_radius,
                                                target_names, needle.run.target_in_near_field);
    if (!near.empty()) res.warnings.push_back(near);
    if (needle::make_friction_law(friction_options(spec, 1))->axial_force_never_falls())
      m.check_axial_force(spec, needle, res.warnings);
    res.needles.push_back(std::move(needle.run));
    needles.push_back(std::move(needle.report));
  }
  m.actions_after(m.sc.needles.size(), probe, res, needles);
  rep["needles"] = needles;
  if (!compared.empty()) rep["compare_linear"] = compare_linear_needles(compared);
  if (m.sc.probe) rep["probe"] = probe.finish(res.probe_steps);
  if (m.sc.needles.empty() && !m.sc.procedure) {  // a static load case: step 0 only
    StaticLoadOutcome<dim> load = run_static_load<dim>(m, res.warnings);
    res.static_load = std::move(load.run);
    if (load.report.contains("compare_linear")) {  // --compare-linear: at the top of simulation
      rep["compare_linear"] = std::move(load.report["compare_linear"]);
      load.report.erase("compare_linear");
    }
    rep["static_load"] = std::move(load.report);
    rep["max_displacement"] = res.static_load->max_displacement;
    rep["max_strain"] = res.static_load->max_strain;
    for (std::size_t t = 0; t < m.sc.targets.size(); ++t)
      rep["final_displacement_" + m.sc.targets[t].name] = res.static_load->target_displacement[t].norm();
  }
  for (const auto& r : res.needles)
    if (!r.unsettled_steps.empty()) res.warnings.push_back(unsettled_warning<dim>(r, m.max_sweeps()));
  for (const auto& spec : m.sc.needles)
    for (auto& w : m.held_path_warnings(spec)) res.warnings.push_back(std::move(w));
  if (!res.warnings.empty()) rep["warnings"] = res.warnings;
  if (!res.needles.empty()) {
    // The first needle's headline numbers at the top level (summary / README).
    const auto& r = res.needles.front();
    rep["final_axial_force"] = r.axial_force.back();
    rep["final_lateral_force"] = r.lateral_force.back();
    for (std::size_t t = 0; t < m.sc.targets.size(); ++t)
      rep["final_displacement_" + m.sc.targets[t].name] = r.target_displacement.back()[t].norm();
    rep["max_displacement"] = r.max_displacement;
    rep["max_strain"] = *std::max_element(r.max_strain.begin(), r.max_strain.end());
    rep["steps_per_second"] = r.steps_per_second;
  }
  rep["model"]["memory_bytes"] = m.model->memory_consumption();  // after the solves: with their caches
  rep["model"]["cells_held"] = m.model->cells_held();  // by rank 0: serial mesh, or owned + ghost cells
  rep["timing"] = {{"build_seconds", m.build_seconds}};
  if (m.sc.needle_list && m.opt.output_file) {
    write_summary_csv<dim>(m.opt.output_file("summary.csv"), res.needles, m.sc);
  }
  if (m.sc.procedure) {
    rep["seeds"] = seeds_report<dim>(res.needles);
    if (m.opt.output_file) write_seeds_csv<dim>(m.opt.output_file("seeds.csv"), res.needles);
    if (m.sc.dose) rep["dose"] = procedure_dose<dim>(m, res.needles);
  }
  return res;
}

template <int dim>
SimulationResult<dim> run_simulation(const MeshModel<dim>& model, const Scenario& scenario,
                                     SimulationOptions options) {
  NeedleSimulation<dim> sim(model, scenario, std::move(options));
  return sim.run();
}

// SimulationContext::region is also called from needle_insertion.cpp (needle.tissues regions): emit it here.
template fem::Region<2> SimulationContext<2>::region(const RegionSpec&) const;
template fem::Region<3> SimulationContext<3>::region(const RegionSpec&) const;
template class NeedleSimulation<2>;
template class NeedleSimulation<3>;
template SimulationResult<2> run_simulation<2>(const MeshModel<2>&, const Scenario&, SimulationOptions);
template SimulationResult<3> run_simulation<3>(const MeshModel<3>&, const Scenario&, SimulationOptions);

}  // namespace vim::pipeline

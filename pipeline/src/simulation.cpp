// Needle-insertion driver (issue 6, DESIGN.md §5): scenario → ElasticModel (frame coordinates) →
// steps of the kinematic / stick-slip / force needle model → VTU/PVD, needle.csv, report JSON.
// The models are described in simulation.hpp.
#include <vim/pipeline/simulation.hpp>

#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/needle.hpp>
#include <vim/pipeline/progress.hpp>
#include <vim/pipeline/scenario_regions.hpp>
#include <vim/pipeline/vtk_output.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <sstream>

namespace vim::pipeline {

namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

template <int dim>
Eigen::Matrix<double, dim, 1> vec(const std::vector<double>& x) {
  Eigen::Matrix<double, dim, 1> v;
  for (int d = 0; d < dim; ++d) v[d] = x[d];
  return v;
}

template <int dim>
json to_json(const Eigen::Matrix<double, dim, 1>& v) {
  json j = json::array();
  for (int d = 0; d < dim; ++d) j.push_back(v[d]);
  return j;
}

std::string step_file(int k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "step_%04d.vtu", k);
  return buf;
}

}  // namespace

template <int dim>
struct NeedleSimulation<dim>::Impl {
  using Mat = Eigen::Matrix<double, dim, dim>;
  Scenario sc;
  SimulationOptions opt;
  int max_sweeps() const { return std::max(1, opt.max_active_set_iterations); }  // stick-slip cap per step
  WorldTransform<dim> tf;
  std::optional<fem::ElasticModel<dim>> model;
  CellLocator<dim> locator;
  std::vector<double> E;
  Vec box_min, box_max;  // frame
  UnstructuredGrid grid;  // world, no fields
  std::vector<std::array<int, 2>> edges;  // degree 2: vertex pairs of the grid's mid-edge points
  std::vector<bool> blocked;
  // Axes of the needle's point constraints: the world axes seen from the frame when a support holds
  // world components of an oblique image, so that a shaft point on such a node leaves the held
  // directions to the support (as on an axis-aligned image); else the frame axes.
  Mat point_axes = Mat::Identity();
  bool voxel = false;
  unsigned degree = 1;
  double build_seconds = 0.0;
  fem::SolverOptions solver;

  void setup(const std::vector<Vec>& vertices);
  fem::Region<dim> region(const RegionSpec& r) const;
  fem::VolumeSupport<dim> volume_support(const BoundaryConditionSpec& bc, const std::string& where) const;
  NeedleRun<dim> run_needle(const NeedleSpec& spec, const std::string& prefix, json& needle_report,
                            bool snap_to_vertices = false);
  std::vector<std::string> held_path_warnings(const NeedleSpec& spec) const;
  void write_step(const std::string& path, const fem::Solution<dim>* s) const;
};

template <int dim>
fem::Region<dim> NeedleSimulation<dim>::Impl::region(const RegionSpec& r) const {
  return scenario_region<dim>(r, box_min, box_max, tf);
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
    anchor = vec<dim>(r.lo);
    lo = lo.cwiseMax(vec<dim>(r.lo)), hi = hi.cwiseMin(vec<dim>(r.hi));
    size = (vec<dim>(r.hi) - vec<dim>(r.lo)).minCoeff();
  } else {
    anchor = vec<dim>(r.center);
    size = r.radius;
    if (r.kind == RegionSpec::Kind::sphere) lo = lo.cwiseMax((anchor.array() - r.radius).matrix()), hi = hi.cwiseMin((anchor.array() + r.radius).matrix());
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
    throw ScenarioError(where + ": the elastic support's spacing " + std::to_string(h) + " gives too many sample points; "
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
    throw ScenarioError(where + ": region " + r.describe() + " holds no sample point of the elastic support inside the image box");
  return sup;
}

template <int dim>
void NeedleSimulation<dim>::Impl::setup(const std::vector<Vec>& vertices) {
  // Geometry checks against the model's box (the image box), then the boundary conditions.
  check_scenario_geometry<dim>(sc, box_min, box_max, tf);
  solver.type = sc.solver_type == "direct" ? fem::SolverOptions::Type::direct
                : sc.solver_type == "amg"  ? fem::SolverOptions::Type::amg
                                           : fem::SolverOptions::Type::automatic;
  solver.tolerance = sc.solver_tolerance;
  blocked.assign(vertices.size(), false);
  for (std::size_t i = 0; i < sc.boundary_conditions.size(); ++i) {
    const auto& bc = sc.boundary_conditions[i];
    const std::string where = sc.where(bc.line) + "boundary_conditions[" + std::to_string(i) + "]";
    if (bc.support == BoundaryConditionSpec::Support::elastic) {
      model->add_volume_support(volume_support(bc, where));
      continue;
    }
    const fem::Region<dim> reg = region(bc.region);
    std::size_t hits = 0;
    for (const auto& v : vertices) hits += reg.contains(v) ? 1 : 0;
    if (hits == 0)
      throw ScenarioError(where + ": region " + bc.region.describe() +
                          " selects no mesh node (regions are in world coordinates; box faces name the image box)");
    if (bc.is_dirichlet()) {
      fem::DirichletBC<dim> d;
      d.region = reg;
      const bool all = std::all_of(bc.components.begin(), bc.components.end(), [](bool b) { return b; });
      if (bc.type == BoundaryConditionSpec::Type::displacement) d.value = tf.vector_to_frame(vec<dim>(bc.value));
      if (!all && tf.axis_aligned()) {
        // Every image axis is a world axis: the world components are frame components.
        for (int c = 0; c < dim; ++c) d.components[c] = bc.components[tf.world_axis_of(c)];
      } else if (!all) {
        // An oblique image: the world axes seen from the frame (columns of Dᵀ), values in world components.
        d.axes = tf.direction.transpose();
        point_axes = d.axes;
        for (int c = 0; c < dim; ++c) d.components[c] = bc.components[c];
        if (bc.type == BoundaryConditionSpec::Type::displacement) d.value = vec<dim>(bc.value);
      }
      model->add_dirichlet(d);
      if (all)
        for (std::size_t v = 0; v < vertices.size(); ++v) blocked[v] = blocked[v] || reg.contains(vertices[v]);
    } else {
      fem::SurfaceLoad<dim> load;
      load.region = reg;
      if (bc.type == BoundaryConditionSpec::Type::pressure)
        load.pressure = bc.value[0];
      else
        load.traction = tf.vector_to_frame(vec<dim>(bc.value));
      model->add_surface_load(load);
    }
  }
  for (const auto& t : sc.targets)
    if (locator.locate(tf.to_frame(vec<dim>(t.position))) < 0)
      throw ScenarioError(sc.where(t.line) + "target '" + t.name + "' is outside the meshed domain");
}

template <int dim>
NeedleSimulation<dim>::NeedleSimulation() : impl_(std::make_unique<Impl>()) {}
template <int dim>
NeedleSimulation<dim>::~NeedleSimulation() = default;
template <int dim>
NeedleSimulation<dim>::NeedleSimulation(NeedleSimulation&&) noexcept = default;

template <int dim>
NeedleSimulation<dim>::NeedleSimulation(const MeshModel<dim>& mm, const Scenario& scenario, SimulationOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  m.sc = scenario;
  m.opt = std::move(options);
  m.tf = mm.transform;
  if (scenario.dim != dim) throw ScenarioError(scenario.where(0) + "scenario was parsed for a " + std::to_string(scenario.dim) + "D image");
  if (mm.mesh.n_cells() == 0) throw std::invalid_argument("needle simulation: the mesh has no cells");
  if (scenario.modulus_from_image && mm.values.size() != mm.mesh.n_cells())
    throw std::invalid_argument("needle simulation: the mesh has no per-element values (voxel means)");
  std::vector<double> mean(mm.mesh.n_cells(), 0.0);
  if (scenario.modulus_from_image)
    for (std::size_t c = 0; c < mean.size(); ++c) mean[c] = mm.values[c].mean;
  m.E = scenario_modulus(scenario, mean);
  m.degree = m.opt.degree ? *m.opt.degree : scenario.degree ? *scenario.degree : 1u;
  m.box_min = mm.mesh.points[0];
  m.box_max = mm.mesh.points[0];
  for (const auto& p : mm.mesh.points) {
    m.box_min = m.box_min.cwiseMin(p);
    m.box_max = m.box_max.cwiseMax(p);
  }
  m.locator = CellLocator<dim>::simplex(mm.mesh);
  m.model.emplace(mm.mesh, m.E, scenario.poisson_ratio, m.degree);
  // P2: quadratic cells carry the mid-edge values (Impl::edges), so ParaView interpolates quadratically.
  m.grid = m.degree == 2 ? quadratic_simplex_grid(mm.mesh, mm.transform, &m.edges)
                         : simplex_grid(mm.mesh, mm.transform);
  m.setup(m.model->vertices());
  m.build_seconds = seconds_since(t0);
}

template <int dim>
NeedleSimulation<dim> NeedleSimulation<dim>::voxel(const Image<dim>& image, const WorldTransform<dim>& transform,
                                                   const Scenario& scenario, SimulationOptions options) {
  NeedleSimulation sim;
  Impl& m = *sim.impl_;
  const auto t0 = Clock::now();
  m.sc = scenario;
  m.opt = std::move(options);
  m.tf = transform;
  m.voxel = true;
  if (scenario.dim != dim) throw ScenarioError(scenario.where(0) + "scenario was parsed for a " + std::to_string(scenario.dim) + "D image");
  check_modulus_image(scenario, image);
  std::vector<double> values(image.data.begin(), image.data.end());
  m.E = scenario_modulus(scenario, values);
  m.box_min = image.box_min();
  m.box_max = image.box_max();
  m.model.emplace(fem::ElasticModel<dim>::voxel_grid(image.size, m.box_min, m.box_max, m.E, scenario.poisson_ratio));
  const auto& verts = m.model->vertices();
  m.locator = CellLocator<dim>::grid(image.size, m.box_min, m.box_max, verts);
  // Hexahedra (quads) in VTK corner order, vertices in the model's numbering.
  UnstructuredGrid& g = m.grid;
  g.vtk_cell_type = dim == 3 ? 12 : 9;
  g.nodes_per_cell = 1 << dim;
  for (const auto& v : verts) {
    const Vec w = transform.to_world(v);
    std::array<double, 3> q{{0, 0, 0}};
    for (int d = 0; d < dim; ++d) q[d] = w[d];
    g.points.push_back(q);
  }
  Vec h;
  for (int d = 0; d < dim; ++d) h[d] = image.spacing[d];
  const auto order2 = voxel_corner_order(transform.direction.determinant() < 0.0);
  std::vector<int> sup;
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const auto idx = image.index_of(k);
    for (int z = 0; z < (dim == 3 ? 2 : 1); ++z)
      for (const auto& c : order2) {
        Vec corner;
        for (int a = 0; a < dim; ++a) {
          const long off = a == 0 ? c[0] : a == 1 ? c[1] : z;
          corner[a] = m.box_min[a] + static_cast<double>(idx[a] + off) * h[a];
        }
        m.locator.locate(corner, &sup);  // a lattice point: its support is the vertex itself
        if (sup.size() != 1) throw std::logic_error("voxel grid: lattice point without a unique vertex");
        g.connectivity.push_back(sup[0]);
      }
  }
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

template <int dim>
void NeedleSimulation<dim>::Impl::write_step(const std::string& rel, const fem::Solution<dim>* s) const {
  UnstructuredGrid g = grid;
  const Mat D = tf.direction;
  const std::size_t nc = E.size();
  if (sc.wants("displacement")) {
    Field f{dim, {}};
    f.values.reserve(g.points.size() * dim);
    const std::size_t nv = g.points.size() - edges.size();
    const std::vector<Vec> mid =
        s && !edges.empty() ? model->edge_midpoint_displacement(edges) : std::vector<Vec>{};
    for (std::size_t v = 0; v < g.points.size(); ++v) {
      const Vec u = !s ? Vec::Zero() : v < nv ? Vec(D * s->vertex_displacement[v]) : Vec(D * mid[v - nv]);
      for (int d = 0; d < dim; ++d) f.values.push_back(u[d]);
    }
    g.point_data["displacement"] = std::move(f);
  }
  // 2D is plane strain: ε_zz = 0 and σ_zz = ν (σ_xx + σ_yy) (= λ tr ε), as von_mises includes it.
  auto tensor = [&](const std::vector<Mat>* t, bool stress) {
    Field f{9, {}};
    f.values.reserve(nc * 9);
    for (std::size_t c = 0; c < nc; ++c) {
      Eigen::Matrix3d w = Eigen::Matrix3d::Zero();
      if (t) w.topLeftCorner<dim, dim>() = D * (*t)[c] * D.transpose();
      if (t && stress && dim == 2) w(2, 2) = sc.poisson_ratio * (*t)[c].trace();
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) f.values.push_back(w(a, b));
    }
    return f;
  };
  if (sc.wants("strain")) g.cell_data["strain"] = tensor(s ? &s->cell_strain : nullptr, false);
  if (sc.wants("stress")) g.cell_data["stress"] = tensor(s ? &s->cell_stress : nullptr, true);
  if (sc.wants("von_mises")) g.cell_data["von_mises"] = Field{1, s ? s->von_mises : std::vector<double>(nc, 0.0)};
  if (sc.wants("youngs_modulus")) g.cell_data["youngs_modulus"] = Field{1, E};
  write_vtu(opt.output_file(rel), g);
}

// The needle's path through held tissue (a fixed or displacement condition, nodes or elastic support):
// the tissue there cannot follow the needle, so the forces grow with the held length, far beyond those
// of free tissue. Legitimate (a needle into a clamp) but rarely meant: one warning per condition crossed,
// with the held length of the path, measured at 1/1000 of the depth.
template <int dim>
std::vector<std::string> NeedleSimulation<dim>::Impl::held_path_warnings(const NeedleSpec& spec) const {
  std::vector<std::string> out;
  const NeedlePath<dim> path = needle_path<dim>(spec, tf);
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
        << (inside > 1 ? " along its path" : reg.contains(path.entry) ? " at its entry" : " at the end of its path");
    else
      w << " runs through the held region " << bc.region.describe() << " of boundary_conditions[" << i << "] over about "
        << std::setprecision(2) << spec.depth * inside / samples << std::setprecision(6) << " " << sc.length_unit
        << " of its " << spec.depth << " " << sc.length_unit << " path";
    w << ": tissue held there cannot follow the needle, so its forces are far larger than in free tissue";
    out.push_back(w.str());
  }
  return out;
}

template <int dim>
NeedleRun<dim> NeedleSimulation<dim>::Impl::run_needle(const NeedleSpec& spec, const std::string& prefix, json& rep,
                                                       bool snap_to_vertices) {
  NeedleRun<dim> run;
  run.name = spec.name;
  const Vec a_world = vec<dim>(spec.direction).normalized();
  run.axis = a_world;
  const Vec entry_w = vec<dim>(spec.entry);
  const NeedlePath<dim> path = needle_path<dim>(spec, tf);
  const Vec& entry = path.entry;
  const Vec& a = path.axis;
  const double pitch = spec.sample_spacing > 0.0 ? spec.sample_spacing : 0.5 * locator.mean_edge_length();
  const std::vector<ShaftPoint<dim>> shaft = sample_shaft<dim>(locator, entry, a, spec.depth, pitch, blocked, snap_to_vertices);
  if (shaft.empty())
    throw ScenarioError(sc.where(spec.line) + "needle '" + spec.name +
                        "': no point of its path lies in the free part of the mesh (is it inside a fixed region?)");
  const std::size_t np = shaft.size();
  const bool force_model = spec.model == NeedleSpec::Model::force;
  const bool slip = !force_model && spec.friction == NeedleSpec::Friction::stick_slip;

  std::vector<std::size_t> active;  // shaft points constrained in the current step
  for (const auto& p : shaft) {
    run.point_s.push_back(p.s);
    run.point_length.push_back(p.length);
  }
  std::vector<Vec> target_f;
  for (const auto& t : sc.targets) target_f.push_back(tf.to_frame(vec<dim>(t.position)));
  const bool write = static_cast<bool>(opt.output_file) && sc.output_every > 0;
  std::vector<std::pair<double, std::string>> pvd;

  auto record = [&](double depth, const fem::Solution<dim>* s, int n_active, int solves) {
    run.depth.push_back(depth);
    run.tip.push_back(entry_w + depth * a_world);
    Vec f = Vec::Zero();
    if (s)
      for (const auto& pf : s->point_force) f -= pf;
    f = tf.vector_to_world(f);
    run.force.push_back(f);
    const double ax = f.dot(a_world);
    run.axial_force.push_back(0.0 - ax);  // +0 at rest
    run.lateral_force.push_back((f - ax * a_world).norm());
    std::vector<Vec> td(target_f.size(), Vec::Zero());
    if (s && !target_f.empty()) {
      const auto u = model->sample(target_f);
      for (std::size_t t = 0; t < u.size(); ++t) td[t] = tf.vector_to_world(u[t]);
    }
    run.target_displacement.push_back(td);
    std::vector<Vec> vd;
    if (s) {
      vd.reserve(s->vertex_displacement.size());
      for (const auto& u : s->vertex_displacement) {
        vd.push_back(tf.vector_to_world(u));
        run.max_displacement = std::max(run.max_displacement, u.norm());
      }
    } else {
      vd.assign(model->vertices().size(), Vec::Zero());
    }
    if (opt.keep_step_fields || run.vertex_displacement.empty())
      run.vertex_displacement.push_back(std::move(vd));
    else
      run.vertex_displacement.back() = std::move(vd);
    std::vector<double> pa(np, 0.0);
    if (s)
      for (std::size_t i = 0; i < active.size() && i < s->point_force.size(); ++i) pa[active[i]] = s->point_force[i].dot(a);
    run.point_axial_force.push_back(std::move(pa));
    run.active_points.push_back(n_active);
    run.solves.push_back(solves);
  };

  // External loads (a prescribed displacement, a pressure, a traction) act from the start: before the
  // tip reaches the first shaft point (step 0 included) the tissue deforms under them alone, not rest.
  const bool loaded = std::any_of(sc.boundary_conditions.begin(), sc.boundary_conditions.end(),
                                  [](const BoundaryConditionSpec& bc) { return bc.type != BoundaryConditionSpec::Type::fixed; });
  int solves_total = 0;
  double solve_time = 0.0;
  fem::Solution<dim> sol;

  std::vector<double> w(np, 0.0);       // axial constraint values (displacement along a)
  // Lateral displacement of each shaft point under the external loads alone (zero without loads): the
  // needle enters tissue the loads have already moved, so a picked-up point keeps it rather than being
  // pulled back to its rest line, which would load the needle with the loads' deformation (a rigid
  // motion of the body would then change the needle forces). The displacement the needle itself causes
  // ahead of the tip is not kept: the point joins the needle on its line, as without loads.
  std::vector<Vec> lateral(np, Vec::Zero());
  std::vector<bool> picked(np, false), picking(np, false);  // passed by the tip (before / in this step)
  bool have_solution = false;
  std::vector<bool> sliding(np, false); // stick-slip: force-controlled at ±limit
  std::vector<double> sign(np, 1.0);
  // Shaft length each point carries at travel d: its segment [start_j, start_j + length_j) as far as the
  // tip has reached, and for the point the tip pushes, everything up to the tip (the sum is d).
  std::vector<double> start(np, 0.0), covered(np, 0.0), limit(np, 0.0);
  for (std::size_t j = 1; j < np; ++j) start[j] = start[j - 1] + shaft[j - 1].length;

  // Solve with axial values `vals` on the picked points; returns the axial force on the body per point.
  auto solve_with = [&](const std::vector<double>& vals) {
    std::vector<fem::PointConstraint<dim>> pts;
    pts.reserve(active.size());
    for (std::size_t j : active) {
      fem::PointConstraint<dim> p;
      p.position = shaft[j].position;
      p.axes = point_axes;
      p.displacement = point_axes.transpose() * (vals[j] * a + lateral[j]);
      pts.push_back(p);
    }
    const auto t = Clock::now();
    sol = opt.monolithic ? model->solve_monolithic(pts, solver) : model->solve(pts, solver);
    solve_time += seconds_since(t);
    ++solves_total;
    std::vector<double> fa(np, 0.0);
    for (std::size_t i = 0; i < active.size(); ++i) fa[active[i]] = sol.point_force[i].dot(a);
    return fa;
  };

  // Axial stiffness map of the current set of active points (rebuilt when a point is picked up).
  AxialMap map;
  std::size_t map_size = 0;
  auto compact = [&](const std::vector<double>& v) {
    Eigen::VectorXd c(active.size());
    for (std::size_t i = 0; i < active.size(); ++i) c[i] = v[active[i]];
    return c;
  };
  auto expand = [&](const Eigen::VectorXd& c, std::vector<double>& v) {
    for (std::size_t i = 0; i < active.size(); ++i) v[active[i]] = c[i];
  };
  auto ensure_map = [&]() {
    if (map_size == active.size()) return;
    map = AxialMap::probe(static_cast<Eigen::Index>(active.size()),
                          [&](const Eigen::VectorXd& wc) {
                            std::vector<double> full(np, 0.0);
                            expand(wc, full);
                            return compact(solve_with(full));
                          },
                          pitch);
    map_size = active.size();
  };

  Progress progress("needle " + spec.name, spec.steps);
  const auto t_run = Clock::now();
  double d_prev = 0.0;
  // Step 0: rest, or the external loads alone.
  if (loaded) {
    solve_with(w);
    std::vector<Vec> at;
    for (const auto& p : shaft) at.push_back(p.position);
    const std::vector<Vec> u = model->sample(at);
    for (std::size_t j = 0; j < np; ++j) lateral[j] = u[j] - u[j].dot(a) * a;
  }
  have_solution = loaded;
  record(0.0, loaded ? &sol : nullptr, 0, loaded ? 1 : 0);
  run.step_seconds.push_back(0.0);
  if (write) {
    write_step(prefix + "steps/" + step_file(0), loaded ? &sol : nullptr);
    pvd.emplace_back(0.0, "steps/" + step_file(0));
  }
  if (slip) run.active_set_sweeps.assign(static_cast<std::size_t>(spec.steps) + 1, 0);
  for (int k = 1; k <= spec.steps; ++k) {
    const double d = spec.depth * static_cast<double>(k) / static_cast<double>(spec.steps);
    const double dd = d - d_prev;
    d_prev = d;
    const int solves_before = solves_total;
    const auto t_step = Clock::now();
    std::vector<double> w_stick(np, 0.0);
    std::size_t last = np;
    active.clear();
    // Pick-up: the tip reaches a material point when it reaches the point's current position
    // s_j + u_j·a (the tissue ahead of the tip has been pushed forward), so it never jumps back.
    // With a cutting distance δ the tip must pass that position by δ; the point is cut δ behind the tip.
    const double cut = d - spec.cutting_distance;
    for (std::size_t j = 0; j < np && shaft[j].s < cut - 1e-9 * spec.depth; ++j) {
      if (picked[j]) continue;
      double ua = 0.0;
      if (have_solution) ua = model->sample({shaft[j].position})[0].dot(a);
      if (shaft[j].s + ua >= cut - 1e-9 * spec.depth) break;
      picking[j] = true;
    }
    for (std::size_t j = 0; j < np; ++j) {
      if (picked[j] || picking[j]) {
        picking[j] = false;
        w_stick[j] = picked[j] ? w[j] + dd : cut - shaft[j].s;
        if (!picked[j]) w[j] = w_stick[j];
        else if (!sliding[j]) w[j] = w_stick[j];
        picked[j] = true;
        active.push_back(j);
        last = j;
      }
    }
    for (std::size_t j : active) {
      covered[j] = j == last ? d - start[j] : std::min(shaft[j].length, d - start[j]);
      limit[j] = spec.max_shear_per_length * covered[j];
    }
    if (active.empty()) {
      // The tip has not reached the first embedded point yet: the needle does not touch the tissue.
      if (loaded) solve_with(w);
      else sol = fem::Solution<dim>{};
      record(d, loaded ? &sol : nullptr, 0, solves_total - solves_before);
    } else if (force_model) {
      ensure_map();
      std::vector<double> target(np, 0.0);
      for (std::size_t j : active) target[j] = spec.friction_per_length * covered[j] + (j == last ? spec.tip_force : 0.0);
      Eigen::VectorXd wc = compact(w);
      map.solve_free(wc, std::vector<bool>(active.size(), true), compact(target));
      expand(wc, w);
      solve_with(w);
      record(d, &sol, static_cast<int>(active.size()), solves_total - solves_before);
    } else if (!slip) {
      solve_with(w);
      record(d, &sol, static_cast<int>(active.size()), solves_total - solves_before);
    } else {
      // Stick-slip: try sticking first; if a load exceeds its limit (or points were sliding), solve the
      // active-set problem on the axial map: sliding points carry ±limit, stuck points move with the needle.
      bool need = false;
      for (std::size_t j : active) need = need || sliding[j];
      if (!need) {
        const std::vector<double> fa = solve_with(w);
        for (std::size_t j : active) need = need || std::abs(fa[j]) > limit[j] * (1.0 + 1e-9);
      }
      if (need) {
        ensure_map();
        const std::size_t m = active.size();
        Eigen::VectorXd wc = compact(w), ws = compact(w_stick), lim = compact(limit);
        std::vector<bool> sl(m);
        Eigen::VectorXd sg(m);
        for (std::size_t i = 0; i < m; ++i) {
          sl[i] = sliding[active[i]];
          sg[i] = sign[active[i]];
        }
        bool settled = false;
        int sweeps = 0;
        for (; sweeps < max_sweeps() && !settled; ++sweeps) {
          map.solve_free(wc, sl, sg.cwiseProduct(lim));
          const Eigen::VectorXd f = map(wc);
          bool changed = false;
          for (std::size_t i = 0; i < m; ++i) {
            if (!sl[i] && std::abs(f[i]) > lim[i] * (1.0 + 1e-9)) {
              sl[i] = true;
              sg[i] = f[i] > 0.0 ? 1.0 : -1.0;
              changed = true;
            } else if (sl[i] && (wc[i] - ws[i]) * sg[i] > 1e-12 * std::max(1.0, std::abs(ws[i]))) {
              // Holding the limit would need the point to move ahead of the needle: it sticks again.
              sl[i] = false;
              wc[i] = ws[i];
              changed = true;
            }
          }
          settled = !changed;
        }
        run.active_set_sweeps[static_cast<std::size_t>(k)] = sweeps;
        if (!settled) run.unsettled_steps.push_back(k);
        expand(wc, w);
        for (std::size_t i = 0; i < m; ++i) {
          sliding[active[i]] = sl[i];
          sign[active[i]] = sg[i];
        }
        solve_with(w);
      }
      record(d, &sol, static_cast<int>(active.size()), solves_total - solves_before);
    }
    have_solution = !active.empty() || loaded;
    run.stats = sol.stats;
    run.step_seconds.push_back(seconds_since(t_step));
    if (write && (k % sc.output_every == 0 || k == spec.steps)) {
      write_step(prefix + "steps/" + step_file(k), active.empty() && !loaded ? nullptr : &sol);
      pvd.emplace_back(d, "steps/" + step_file(k));
    }
    if (opt.progress) {
      std::ostringstream msg;
      msg << "step " << k << "/" << spec.steps << ", depth " << d << " " << sc.length_unit << ", axial force "
          << run.axial_force.back() << ", " << active.size() << " shaft points";
      progress.report(k, msg.str());
    }
  }
  const double run_seconds = seconds_since(t_run);
  run.solve_seconds = solve_time;
  run.steps_per_second = run_seconds > 0.0 ? spec.steps / run_seconds : 0.0;

  if (opt.output_file) {
    if (write) write_pvd(opt.output_file(prefix + "simulation.pvd"), pvd);
    write_text_atomically(opt.output_file(prefix + "needle.csv"), [&](std::ostream& o) {
      const char* axes = "xyz";
      o << "step,depth";
      for (int d = 0; d < dim; ++d) o << ",tip_" << axes[d];
      o << ",axial_force,lateral_force";
      for (const auto& t : sc.targets) {
        for (int d = 0; d < dim; ++d) o << "," << t.name << "_d" << axes[d];
        o << "," << t.name << "_norm";
      }
      o << "\n" << std::setprecision(10);
      for (std::size_t k = 0; k < run.depth.size(); ++k) {
        o << k << "," << run.depth[k];
        for (int d = 0; d < dim; ++d) o << "," << run.tip[k][d];
        o << "," << run.axial_force[k] << "," << run.lateral_force[k];
        for (const auto& u : run.target_displacement[k]) {
          for (int d = 0; d < dim; ++d) o << "," << u[d];
          o << "," << u.norm();
        }
        o << "\n";
      }
    });
  }

  // Report.
  rep["name"] = spec.name;
  rep["entry"] = spec.entry;
  rep["direction"] = spec.direction;
  rep["depth"] = spec.depth;
  rep["steps"] = spec.steps;
  rep["diameter"] = spec.diameter;
  rep["model"] = force_model ? "force" : "kinematic";
  rep["friction"] = slip ? "stick-slip" : "stick";
  if (slip) rep["max_shear_per_length"] = spec.max_shear_per_length;
  if (force_model) {
    rep["tip_force"] = spec.tip_force;
    rep["friction_per_length"] = spec.friction_per_length;
  }
  if (!force_model) rep["cutting_distance"] = spec.cutting_distance;
  rep["shaft_points"] = np;
  rep["shaft_pitch"] = pitch;
  if (!prefix.empty()) rep["folder"] = prefix;
  json per = json::object();
  per["depth"] = run.depth;
  per["axial_force"] = run.axial_force;
  per["lateral_force"] = run.lateral_force;
  per["active_points"] = run.active_points;
  per["solves"] = run.solves;
  if (slip) {
    per["active_set_sweeps"] = run.active_set_sweeps;
    rep["unsettled_steps"] = run.unsettled_steps;
  }
  json forces = json::array();
  for (const auto& f : run.force) forces.push_back(to_json<dim>(f));
  per["force"] = forces;
  json targets = json::object();
  for (std::size_t t = 0; t < sc.targets.size(); ++t) {
    json arr = json::array();
    for (const auto& step : run.target_displacement) arr.push_back(to_json<dim>(step[t]));
    targets[sc.targets[t].name] = arr;
  }
  per["target_displacement"] = targets;
  rep["per_step"] = per;
  json final_targets = json::object();
  for (std::size_t t = 0; t < sc.targets.size(); ++t) {
    const Vec u = run.target_displacement.back()[t];
    final_targets[sc.targets[t].name] = {{"displacement", to_json<dim>(u)}, {"norm", u.norm()}};
  }
  rep["final"] = {{"axial_force", run.axial_force.back()},
                  {"lateral_force", run.lateral_force.back()},
                  {"force", to_json<dim>(run.force.back())},
                  {"targets", final_targets}};
  rep["max_displacement"] = run.max_displacement;
  rep["solver"] = {{"method", run.stats.method}, {"n_dofs", run.stats.n_dofs}, {"assemble_seconds", run.stats.assemble_seconds},
                   {"solves", solves_total}, {"monolithic", opt.monolithic}};
  rep["timing"] = {{"run_seconds", run_seconds}, {"solve_seconds", solve_time}, {"steps_per_second", run.steps_per_second}};
  return run;
}

template <int dim>
SimulationResult<dim> NeedleSimulation<dim>::run() {
  Impl& m = *impl_;
  SimulationResult<dim> res;
  json& rep = res.report;
  rep["scenario"] = {{"file", m.sc.source}, {"yaml", m.sc.text}};
  rep["units"] = {{"length", m.sc.length_unit}, {"modulus", m.sc.modulus_unit}};
  for (const auto& t : m.sc.targets) res.target_names.push_back(t.name);
  double emin = std::numeric_limits<double>::infinity(), emax = -emin, esum = 0.0;
  for (double e : m.E) {
    emin = std::min(emin, e);
    emax = std::max(emax, e);
    esum += e;
  }
  rep["model"] = {{"kind", m.voxel ? "voxel" : "simplex"},
                  {"cells", m.E.size()},
                  {"vertices", m.model->vertices().size()},
                  {"dofs", m.model->n_dofs()},
                  {"degree", m.voxel ? 1u : m.degree},
                  {"poisson_ratio", m.sc.poisson_ratio},
                  {"youngs_modulus", {{"min", emin}, {"max", emax}, {"mean", esum / static_cast<double>(m.E.size())}}},
                  {"source", m.sc.modulus_from_image ? "image" : "constant"},
                  {"scale", m.sc.scale}};
  if (m.sc.clamp) rep["model"]["clamp"] = {m.sc.clamp->first, m.sc.clamp->second};
  rep["boundary_conditions"] = m.sc.boundary_conditions.size();
  json needles = json::array();
  for (const auto& spec : m.sc.needles) {
    json nr;
    const std::string prefix = m.sc.needle_list ? spec.name + "/" : "";
    const std::string who = spec.name.empty() ? std::string("the needle") : "needle '" + spec.name + "'";
    const double edge = m.locator.mean_edge_length();
    if ((m.voxel || m.degree == 1) && spec.sample_spacing > 0.0 && spec.sample_spacing < 0.5 * edge) {
      // Several joined points per linear element impose the linear field of their displacements on
      // the whole element, also beyond the tip (a probe: 1 mm spacing on 6 mm tetrahedra moved the tissue
      // 3 mm ahead of the tip 2.5 mm backwards, and the axial force went negative).
      std::ostringstream w;
      w << m.sc.where(spec.line) << who << ": needle.sample_spacing = " << spec.sample_spacing
        << " is below half the mean element edge (" << edge << "): linear elements impose the displacements of "
        << "the shaft points in one element on all of it, also ahead of the tip, so the tissue there can be pulled "
        << "back and the forces can drop or change sign; leave sample_spacing out (half the mean edge) or use degree 2";
      res.warnings.push_back(w.str());
    }
    try {
      try {
        res.needles.push_back(m.run_needle(spec, prefix, nr));
      } catch (const fem::DependentPointConstraints& e) {
        // Shaft points inside a chain of collinear mesh edges (a path along a box edge or a grid line):
        // run again with the points on those edges moved to the edges' vertices (sample_shaft).
        std::ostringstream w;
        w << m.sc.where(spec.line) << who << ": its shaft points along mesh edges were nearly dependent (" << e.what()
          << "); ran it again with the shaft sampled at the mesh vertices on its path";
        nr = json();
        try {
          res.needles.push_back(m.run_needle(spec, prefix, nr, true));
          res.warnings.push_back(w.str());
          nr["shaft_sampled_at_vertices"] = true;
        } catch (const fem::DependentPointConstraints&) {
          // Still dependent: e.g. a path through cells that meet at single vertices (parallel to the
          // diagonals of a grid, about halfway between them), where one point per cell at the default
          // spacing (half the mean edge) made the constraints conflict. With the default spacing, try
          // one and two mean element edges; an explicit sample_spacing is the user's choice (the
          // error below suggests a value).
          if (spec.sample_spacing > 0.0) throw;
          NeedleSpec coarser = spec;
          bool done = false;
          for (const double factor : {1.0, 2.0}) {
            coarser.sample_spacing = factor * edge;
            nr = json();
            try {
              res.needles.push_back(m.run_needle(coarser, prefix, nr, true));
            } catch (const fem::DependentPointConstraints&) {
              if (factor == 2.0) throw;
              continue;
            }
            done = true;
            break;
          }
          if (!done) throw;
          std::ostringstream c;
          c << m.sc.where(spec.line) << who << ": its shaft points at the default spacing (" << 0.5 * edge
            << ", half the mean element edge) were nearly dependent (" << e.what() << "); ran it again with "
            << "sample_spacing = " << coarser.sample_spacing << " and the shaft at the mesh vertices where it "
            << "runs along edges";
          res.warnings.push_back(c.str());
          nr["shaft_sampled_at_vertices"] = true;
          nr["shaft_pitch_increased_from"] = 0.5 * edge;
        }
      }
    } catch (const fem::SingularConstraints& e) {  // the first solve: name the scenario's conditions
      const int line = m.sc.boundary_conditions.empty() ? 0 : m.sc.boundary_conditions.front().line;
      throw ScenarioError(m.sc.where(line) + "boundary_conditions: " + e.what());
    } catch (const fem::DependentPointConstraints& e) {
      // Shaft points closer together than the elements resolve: a path along element edges or through a
      // row of vertices, or a sample_spacing below the element size.
      std::ostringstream s;
      s << m.sc.where(spec.line) << who << ": its embedded shaft points constrain nearly the same displacements ("
        << e.what() << "); this happens where shaft points are closer together than the elements can resolve: a path "
        << "along element edges or through a row of mesh vertices";
      if (spec.sample_spacing > 0.0 && spec.sample_spacing < edge)
        s << ", or needle.sample_spacing = " << spec.sample_spacing << " below the mean element edge (" << edge << ")";
      s << "; set needle.sample_spacing to about the mean element edge (" << edge
        << ") or more (the default is half of it), or move the path slightly";
      throw ScenarioError(s.str());
    }
    if (spec.model == NeedleSpec::Model::kinematic && spec.friction == NeedleSpec::Friction::stick) {
      // A stuck shaft advancing into linear elastic tissue pushes it: the axial force should not be
      // negative nor fall. Where it does, the discretisation holds the tissue at the tip back (a shaft
      // point joins at rest, and P1 spreads that over its whole element): say so, with the remedies.
      const std::vector<double>& f = res.needles.back().axial_force;
      double largest = 0.0;
      std::vector<int> dips;
      for (std::size_t k = 1; k < f.size(); ++k) {
        largest = std::max(largest, std::abs(f[k]));
        if (f[k] < 0.0 || f[k] < f[k - 1] - 0.05 * largest) dips.push_back(static_cast<int>(k));
      }
      if (!dips.empty()) {
        const std::size_t k = static_cast<std::size_t>(dips.front());
        std::ostringstream w;
        w << m.sc.where(spec.line) << who << ": the axial force is negative or falls at " << dips.size() << " of " << f.size() - 1 << " steps (first: step " << k << ", " << f[k - 1] << " -> " << f[k]
          << "), which a stuck needle pushing into elastic tissue does not do: the shaft points that join at the tip "
          << "hold the tissue there at rest, and " << (m.voxel || m.degree == 1 ? "linear elements spread that over"
                                                                                 : "the elements spread that over")
          << " their whole size; " << (m.voxel || m.degree == 1 ? "use mesh.degree: 2, " : "")
          << "refine along the path (mesh.needle_refinement, more nodes) or set needle.sample_spacing to about the "
          << "mean element edge (" << edge << ")";
        res.warnings.push_back(w.str());
        nr["axial_force_dips"] = dips;
      }
    }
    needles.push_back(nr);
  }
  rep["needles"] = needles;
  for (const auto& r : res.needles) {
    if (r.unsettled_steps.empty()) continue;
    std::ostringstream w;
    w << (r.name.empty() ? std::string("the needle") : "needle '" + r.name + "'") << ": at "
      << r.unsettled_steps.size() << " of " << r.depth.size() - 1 << " steps (first: step " << r.unsettled_steps.front()
      << ") the stick-slip active set still changed after " << m.max_sweeps()
      << (m.max_sweeps() > 1 ? " sweeps" : " sweep")
      << "; those steps keep the last iterate, so a shaft load may exceed its friction limit (try more steps)";
    res.warnings.push_back(w.str());
  }
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
    rep["steps_per_second"] = r.steps_per_second;
  }
  rep["timing"] = {{"build_seconds", m.build_seconds}};
  if (m.sc.needle_list && m.opt.output_file) {
    write_text_atomically(m.opt.output_file("summary.csv"), [&](std::ostream& o) {
      o << "name,depth,steps,axial_force,lateral_force,max_displacement,steps_per_second";
      for (const auto& t : m.sc.targets) o << "," << t.name << "_norm";
      o << "\n" << std::setprecision(10);
      for (const auto& r : res.needles) {
        o << r.name << "," << r.depth.back() << "," << r.depth.size() - 1 << "," << r.axial_force.back() << ","
          << r.lateral_force.back() << "," << r.max_displacement << "," << r.steps_per_second;
        for (const auto& u : r.target_displacement.back()) o << "," << u.norm();
        o << "\n";
      }
    });
  }
  return res;
}

template <int dim>
SimulationResult<dim> run_simulation(const MeshModel<dim>& model, const Scenario& scenario, SimulationOptions options) {
  NeedleSimulation<dim> sim(model, scenario, std::move(options));
  return sim.run();
}

template class NeedleSimulation<2>;
template class NeedleSimulation<3>;
template SimulationResult<2> run_simulation<2>(const MeshModel<2>&, const Scenario&, SimulationOptions);
template SimulationResult<3> run_simulation<3>(const MeshModel<3>&, const Scenario&, SimulationOptions);

}  // namespace vim::pipeline

// The files and report entries of a needle simulation (simulation_output.hpp).
#include "simulation/simulation_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <vim/fem/distributed.hpp>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "simulation/solve_comm.hpp"

namespace vim::pipeline {

using json = nlohmann::json;

namespace {

template <int dim>
json to_json(const Eigen::Matrix<double, dim, 1>& v) {
  json j = json::array();
  for (int d = 0; d < dim; ++d) j.push_back(v[d]);
  return j;
}

}  // namespace

std::string step_file(int k, int mpi_ranks) {
  char buf[32];
  std::snprintf(buf, sizeof buf, mpi_ranks > 1 ? "step_%04d.pvtu" : "step_%04d.vtu", k);
  return buf;
}

std::string needle_step_file(int k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "needle_%04d.vtp", k);
  return buf;
}

template <int dim>
void write_needle_vtp(const std::filesystem::path& path,
                      const std::vector<Eigen::Matrix<double, dim, 1>>& shape,
                      const Eigen::Matrix<double, dim, 1>& entry, const Eigen::Matrix<double, dim, 1>& axis) {
  PolyLines lines;
  Field deflection{3, {}};
  lines.lines.emplace_back();
  for (const auto& x : shape) {
    std::array<double, 3> p{};
    const Eigen::Matrix<double, dim, 1> along = entry + (x - entry).dot(axis) * axis;
    for (int d = 0; d < dim; ++d) p[d] = x[d];
    for (int d = 0; d < 3; ++d) deflection.values.push_back(d < dim ? x[d] - along[d] : 0.0);
    lines.lines.back().push_back(static_cast<long>(lines.points.size()));
    lines.points.push_back(p);
  }
  lines.point_data["deflection"] = std::move(deflection);
  write_vtp(path, lines);
}

namespace {

// The scenario's output fields of a solution (zero fields when null: rest) on `g`, whose points and
// cells are the world grid's `points` and `cells` (null: all of them, in order).
template <int dim>
void add_step_fields(const SimulationContext<dim>& ctx, const fem::Solution<dim>* s, UnstructuredGrid& g,
                     const std::vector<std::size_t>* points, const std::vector<std::size_t>* cells) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  using Mat = Eigen::Matrix<double, dim, dim>;
  const Scenario& sc = ctx.sc;
  const Mat D = ctx.tf.direction;
  const std::size_t np = g.points.size(), nc = g.n_cells();
  const auto point = [points](std::size_t v) { return points ? (*points)[v] : v; };
  const auto cell = [cells](std::size_t c) { return cells ? (*cells)[c] : c; };
  if (sc.wants("displacement")) {
    Field f{dim, {}};
    f.values.reserve(np * dim);
    // Degree 2: the grid's mid-edge points follow its vertices; their values are the P2 edge DoFs of the
    // last solve (s is the model's last solution).
    const std::size_t nv = ctx.grid->points.size() - ctx.edges.size();
    const std::vector<Vec> mid =
        s && !ctx.edges.empty() ? ctx.model->edge_midpoint_displacement(ctx.edges) : std::vector<Vec>{};
    for (std::size_t k = 0; k < np; ++k) {
      const std::size_t v = point(k);
      const Vec u = !s ? Vec::Zero() : v < nv ? Vec(D * s->vertex_displacement[v]) : Vec(D * mid[v - nv]);
      for (int d = 0; d < dim; ++d) f.values.push_back(u[d]);
    }
    g.point_data["displacement"] = std::move(f);
  }
  // 2D is plane strain: ε_zz = 0 and σ_zz = ν (σ_xx + σ_yy) (= λ tr ε), as von_mises includes it.
  auto tensor = [&](const std::vector<Mat>* t, bool stress) {
    Field f{9, {}};
    f.values.reserve(nc * 9);
    for (std::size_t k = 0; k < nc; ++k) {
      const std::size_t c = cell(k);
      Eigen::Matrix3d w = Eigen::Matrix3d::Zero();
      if (t) w.topLeftCorner<dim, dim>() = D * (*t)[c] * D.transpose();
      if (t && stress && dim == 2) w(2, 2) = sc.poisson_ratio * (*t)[c].trace();
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) f.values.push_back(w(a, b));
    }
    return f;
  };
  auto per_cell = [&](const std::vector<double>* values) {
    Field f{1, {}};
    f.values.reserve(nc);
    for (std::size_t k = 0; k < nc; ++k) f.values.push_back(values ? (*values)[cell(k)] : 0.0);
    return f;
  };
  if (sc.wants("strain")) g.cell_data["strain"] = tensor(s ? &s->cell_strain : nullptr, false);
  if (sc.wants("stress")) g.cell_data["stress"] = tensor(s ? &s->cell_stress : nullptr, true);
  if (sc.wants("von_mises")) g.cell_data["von_mises"] = per_cell(s ? &s->von_mises : nullptr);
  if (sc.wants("youngs_modulus")) g.cell_data["youngs_modulus"] = per_cell(&ctx.E);
}

// A step of a run over MPI ranks, on every rank: its piece (the cells it owns in the distributed
// solves) through a temporary name; rank 0, once every piece is in place, the .pvtu that names them,
// so that a stopped run never leaves a .pvtu naming a missing piece.
template <int dim>
void write_step_pieces(const SimulationContext<dim>& ctx, const std::string& relative,
                       const fem::Solution<dim>* s) {
  int rank = 0;
  const MPI_Comm comm = solve_comm(ctx.opt);
  MPI_Comm_rank(comm, &rank);
  const std::vector<std::size_t> cells = fem::owned_cells(*ctx.model, comm);
  std::vector<std::size_t> points;
  UnstructuredGrid piece = grid_cells(*ctx.grid, cells, &points);
  add_step_fields<dim>(ctx, s, piece, &points, &cells);
  const auto& file = rank == 0 ? ctx.opt.output_file : ctx.opt.piece_file;
  // rank 0 registers every piece in the output folder (creating steps/) before any rank writes one
  if (rank == 0)
    for (int r = 0; r < ctx.opt.mpi_ranks; ++r) file(pvtu_piece(relative, r));
  MPI_Barrier(comm);
  write_vtu(file(pvtu_piece(relative, rank)), piece);
  MPI_Barrier(comm);
  if (rank == 0) write_pvtu(file(relative), ctx.opt.mpi_ranks, piece);
}

}  // namespace

template <int dim>
void write_step_vtu(const SimulationContext<dim>& ctx, const std::string& relative,
                    const fem::Solution<dim>* s) {
  if (ctx.opt.mpi_ranks > 1) return write_step_pieces<dim>(ctx, relative, s);
  UnstructuredGrid g = *ctx.grid;
  add_step_fields<dim>(ctx, s, g, nullptr, nullptr);
  write_vtu(ctx.opt.output_file(relative), g);
}

template <int dim>
void write_needle_csv(const std::filesystem::path& path, const NeedleRun<dim>& run, const Scenario& sc) {
  write_text_atomically(path, [&](std::ostream& o) {
    const char* axes = "xyz";
    o << "step,depth";
    for (int d = 0; d < dim; ++d) o << ",tip_" << axes[d];
    o << ",axial_force,lateral_force,friction_force,tip_force,max_strain";
    for (const auto& t : sc.targets) {
      for (int d = 0; d < dim; ++d) o << "," << t.name << "_d" << axes[d];
      o << "," << t.name << "_norm";
    }
    const bool near = !run.near_field_strain.empty();  // 3D: the shaft's near field
    if (near) {
      o << ",near_field_strain,small_strain_radius";
      for (const auto& t : sc.targets) o << "," << t.name << "_in_near_field";
    }
    const bool flexible = !run.tip_deviation.empty();  // needle.flexible: the bent needle
    if (flexible) {
      for (int d = 0; d < dim; ++d) o << ",tip_deviation_" << axes[d];
      o << ",tip_deviation_norm,tip_angle";
      for (const char* name : {"base_force_", "base_moment_"})
        for (int d = 0; d < dim; ++d) o << "," << name << axes[d];
    }
    o << "\n" << std::setprecision(10);
    for (std::size_t k = 0; k < run.depth.size(); ++k) {
      o << k << "," << run.depth[k];
      for (int d = 0; d < dim; ++d) o << "," << run.tip[k][d];
      o << "," << run.axial_force[k] << "," << run.lateral_force[k] << "," << run.friction_force[k] << ","
        << run.tip_force[k] << "," << run.max_strain[k];
      for (const auto& u : run.target_displacement[k]) {
        for (int d = 0; d < dim; ++d) o << "," << u[d];
        o << "," << u.norm();
      }
      if (near) {
        o << "," << run.near_field_strain[k] << "," << run.small_strain_radius[k];
        for (int inside : run.target_in_near_field[k]) o << "," << inside;
      }
      if (flexible) {
        for (int d = 0; d < dim; ++d) o << "," << run.tip_deviation[k][d];
        o << "," << run.tip_deviation[k].norm() << "," << run.tip_angle[k];
        for (int d = 0; d < dim; ++d) o << "," << run.base_force[k][d];
        for (int d = 0; d < dim; ++d) o << "," << run.base_moment[k][d];
      }
      o << "\n";
    }
  });
}

template <int dim>
void write_summary_csv(const std::filesystem::path& path, const std::vector<NeedleRun<dim>>& needles,
                       const Scenario& sc) {
  write_text_atomically(path, [&](std::ostream& o) {
    o << "name,depth,steps,axial_force,lateral_force,max_displacement,steps_per_second";
    for (const auto& t : sc.targets) o << "," << t.name << "_norm";
    o << "\n" << std::setprecision(10);
    for (const auto& r : needles) {
      o << r.name << "," << r.depth.back() << "," << r.depth.size() - 1 << "," << r.axial_force.back() << ","
        << r.lateral_force.back() << "," << r.max_displacement << "," << r.steps_per_second;
      for (const auto& u : r.target_displacement.back()) o << "," << u.norm();
      o << "\n";
    }
  });
}

// needle.flexible: the tube and its bevel, per step the tip (bent), its deviation from the planned line,
// its angle to it and the base holder's force and moment on the needle, and per target the distance of
// the final tip from the target's final position.
template <int dim>
void add_flexible_report(const Scenario& sc, const NeedleSpec& spec, const NeedleRun<dim>& run, json& rep,
                         json& per) {
  const FlexibleSpec& f = *spec.flexible;
  json flexible = {{"youngs_modulus", f.youngs_modulus},
                   {"inner_diameter", f.inner_diameter},
                   {"free_length", f.free_length},
                   {"base_offset", f.base_offset}};
  if (spec.bevel) {
    flexible["bevel"] = {{"angle", spec.bevel->angle}, {"side", spec.bevel->side}};
    json rotations = json::array();
    for (const RotationSpec& r : spec.rotations)
      rotations.push_back({{"depth", r.depth}, {"angle", r.angle}});
    flexible["rotations"] = rotations;
  }
  rep["flexible"] = flexible;
  json tip = json::array(), deviation = json::array(), norm = json::array(), force = json::array(),
       moment = json::array();
  for (std::size_t k = 0; k < run.tip_deviation.size(); ++k) {
    tip.push_back(to_json<dim>(run.tip[k]));
    deviation.push_back(to_json<dim>(run.tip_deviation[k]));
    norm.push_back(run.tip_deviation[k].norm());
    force.push_back(to_json<dim>(run.base_force[k]));
    moment.push_back(to_json<dim>(run.base_moment[k]));
  }
  per["tip"] = tip;
  per["tip_deviation"] = deviation;
  per["tip_deviation_norm"] = norm;
  per["tip_angle"] = run.tip_angle;
  per["base_force"] = force;
  per["base_moment"] = moment;
  json shapes = json::array();  // the needle as a polyline from its base to its tip
  for (const auto& shape : run.shape) {
    json line = json::array();
    for (const auto& x : shape) line.push_back(to_json<dim>(x));
    shapes.push_back(line);
  }
  per["needle_shape"] = shapes;
  json to_target = json::object();
  for (std::size_t t = 0; t < sc.targets.size(); ++t) {
    const Eigen::Matrix<double, dim, 1> target =
        spec_vector<dim>(sc.targets[t].position) + run.target_displacement.back()[t];
    to_target[sc.targets[t].name] = (run.tip.back() - target).norm();
  }
  rep["final_tip_to_target"] = to_target;
}

template <int dim>
void write_seeds_csv(const std::filesystem::path& path, const std::vector<NeedleRun<dim>>& needles) {
  static const char* const axes[] = {"x", "y", "z"};
  write_text_atomically(path, [&](std::ostream& o) {
    o << "needle,depth";
    for (const char* what : {"planned", "release", "final", "error"})
      for (int d = 0; d < dim; ++d) o << "," << what << "_" << axes[d];
    o << ",error_norm,release_step\n" << std::setprecision(12);
    for (const auto& r : needles)
      for (const auto& seed : r.seeds) {
        o << r.name << "," << seed.depth;
        for (const auto& v : {seed.planned, seed.planned, seed.final_position(), seed.error()})
          for (int d = 0; d < dim; ++d) o << "," << v[d];
        o << "," << seed.error().norm() << "," << seed.release_step << "\n";
      }
  });
}

template <int dim>
void write_seed_points(const std::filesystem::path& path,
                       const std::vector<Eigen::Matrix<double, dim, 1>>& position,
                       const std::vector<Eigen::Matrix<double, dim, 1>>& planned,
                       const std::vector<int>& needle) {
  UnstructuredGrid g;
  g.vtk_cell_type = 1;  // VTK_VERTEX
  g.nodes_per_cell = 1;
  Field number{1, {}}, error{3, {}};
  for (std::size_t i = 0; i < position.size(); ++i) {
    std::array<double, 3> x{};
    for (int d = 0; d < dim; ++d) x[d] = position[i][d];
    g.points.push_back(x);
    g.connectivity.push_back(static_cast<long>(i));
    number.values.push_back(needle[i]);
    for (int d = 0; d < 3; ++d) error.values.push_back(d < dim ? position[i][d] - planned[i][d] : 0.0);
  }
  g.point_data["needle"] = std::move(number);
  g.point_data["error"] = std::move(error);
  write_vtu(path, g);
}

template <int dim>
json seeds_report(const std::vector<NeedleRun<dim>>& needles) {
  const auto stats = [](const std::vector<double>& e) {
    double sum = 0.0, sq = 0.0, largest = 0.0;
    for (double x : e) sum += x, sq += x * x, largest = std::max(largest, x);
    const double n = static_cast<double>(std::max<std::size_t>(e.size(), 1));
    return json{{"count", e.size()},
                {"mean_error", sum / n},
                {"rms_error", std::sqrt(sq / n)},
                {"max_error", largest}};
  };
  json per = json::object();
  std::vector<double> all;
  for (const auto& r : needles) {
    if (r.seeds.empty()) continue;
    std::vector<double> e;
    for (const auto& seed : r.seeds) e.push_back(seed.error().norm());
    per[r.name] = stats(e);
    all.insert(all.end(), e.begin(), e.end());
  }
  return {{"file", "seeds.csv"}, {"needles", per}, {"all", stats(all)}};
}

template <int dim>
json needle_report(const NeedleSpec& spec, const NeedleRun<dim>& run, const needle::FrictionLaw& law,
                   double pitch, const std::string& prefix, double run_seconds, int solves, bool monolithic,
                   const Scenario& sc) {
  json rep;
  rep["name"] = spec.name;
  rep["entry"] = spec.entry;
  rep["direction"] = spec.direction;
  rep["depth"] = spec.depth;
  rep["steps"] = spec.steps;
  rep["diameter"] = spec.diameter;
  const needle::LawDescription law_keys = law.describe();
  rep["model"] = law_keys.model;
  rep["friction"] = law_keys.friction;
  for (const auto& [key, value] : law_keys.parameters) rep[key] = value;
  rep["shaft_points"] = run.point_s.size();
  if (!spec.tissues.empty()) {
    // needle.tissues as used: per shaft point the entry that holds it (-1: the needle's own values).
    json tissues = json::array();
    for (const TissueSpec& t : spec.tissues)
      tissues.push_back(
          {{"region", t.describe()},
           {"cutting_force", t.cutting_force.value_or(spec.cutting_force)},
           {"max_shear_per_length", t.max_shear_per_length.value_or(spec.max_shear_per_length)}});
    rep["tissues"] = tissues;
    rep["point_tissue"] = run.point_tissue;
  }
  rep["shaft_pitch"] = pitch;
  if (!prefix.empty()) rep["folder"] = prefix;
  json per = json::object();
  per["depth"] = run.depth;
  per["axial_force"] = run.axial_force;
  per["lateral_force"] = run.lateral_force;
  per["friction_force"] = run.friction_force;
  per["tip_force"] = run.tip_force;
  per["tip_cutting"] = run.tip_cutting;
  per["max_strain"] = run.max_strain;
  if (!run.near_field_strain.empty()) {
    per["near_field_strain"] = run.near_field_strain;
    per["small_strain_radius"] = run.small_strain_radius;
  }
  per["active_points"] = run.active_points;
  per["solves"] = run.solves;
  if (law.has_active_set()) {
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
  if (!run.target_in_near_field.empty()) {  // the steps at which each target lies in that near field
    json inside = json::object();
    for (std::size_t t = 0; t < sc.targets.size(); ++t) {
      json steps = json::array();
      for (std::size_t k = 0; k < run.target_in_near_field.size(); ++k)
        if (run.target_in_near_field[k][t]) steps.push_back(k);
      inside[sc.targets[t].name] = steps;
    }
    per["targets_in_near_field"] = inside;
  }
  if (!run.tip_deviation.empty()) add_flexible_report<dim>(sc, spec, run, rep, per);
  rep["per_step"] = per;
  json punctures = json::array();
  for (const auto& p : run.punctures)
    punctures.push_back(
        {{"depth", p.depth}, {"force_before", p.force_before}, {"force_after", p.force_after}});
  rep["punctures"] = punctures;
  json final_targets = json::object();
  for (std::size_t t = 0; t < sc.targets.size(); ++t) {
    const auto u = run.target_displacement.back()[t];
    final_targets[sc.targets[t].name] = {{"displacement", to_json<dim>(u)}, {"norm", u.norm()}};
  }
  rep["final"] = {{"axial_force", run.axial_force.back()},
                  {"lateral_force", run.lateral_force.back()},
                  {"friction_force", run.friction_force.back()},
                  {"tip_force", run.tip_force.back()},
                  {"force", to_json<dim>(run.force.back())},
                  {"max_strain", run.max_strain.back()},
                  {"targets", final_targets}};
  rep["max_displacement"] = run.max_displacement;
  rep["solver"] = {{"method", run.stats.method},
                   {"n_dofs", run.stats.n_dofs},
                   {"assemble_seconds", run.stats.assemble_seconds},
                   {"solves", solves},
                   {"monolithic", monolithic}};
  if (!run.stats.reason.empty()) rep["solver"]["reason"] = run.stats.reason;
  rep["timing"] = {{"run_seconds", run_seconds},
                   {"solve_seconds", run.solve_seconds},
                   {"precompute_seconds", run.precompute_seconds},
                   {"stepping_seconds", run.stepping_seconds},
                   {"steps_per_second", run.steps_per_second}};
  return rep;
}

template <int dim>
json model_report(const SimulationContext<dim>& m) {
  double emin = std::numeric_limits<double>::infinity(), emax = -emin, esum = 0.0;
  for (double e : m.E) {
    emin = std::min(emin, e);
    emax = std::max(emax, e);
    esum += e;
  }
  json model = {
      {"kind", m.voxel ? "voxel" : "simplex"},
      {"cells", m.E.size()},
      {"vertices", m.model->vertices().size()},
      {"dofs", m.model->n_dofs()},
      {"degree", m.voxel ? 1u : m.degree},
      {"poisson_ratio", m.sc.poisson_ratio},
      {"youngs_modulus", {{"min", emin}, {"max", emax}, {"mean", esum / static_cast<double>(m.E.size())}}},
      {"source", m.sc.modulus_from_image ? "image" : "constant"},
      {"scale", m.sc.scale}};
  if (m.sc.clamp) model["clamp"] = {m.sc.clamp->first, m.sc.clamp->second};
  return model;
}

#define VIM_SIMULATION_OUTPUT(dim)                                                                           \
  template void write_step_vtu<dim>(const SimulationContext<dim>&, const std::string&,                       \
                                    const fem::Solution<dim>*);                                              \
  template void write_needle_csv<dim>(const std::filesystem::path&, const NeedleRun<dim>&, const Scenario&); \
  template void write_summary_csv<dim>(const std::filesystem::path&, const std::vector<NeedleRun<dim>>&,     \
                                       const Scenario&);                                                     \
  template json needle_report<dim>(const NeedleSpec&, const NeedleRun<dim>&, const needle::FrictionLaw&,     \
                                   double, const std::string&, double, int, bool, const Scenario&);          \
  template json model_report<dim>(const SimulationContext<dim>&);                                            \
  template void write_seeds_csv<dim>(const std::filesystem::path&, const std::vector<NeedleRun<dim>>&);      \
  template void write_seed_points<dim>(                                                                      \
      const std::filesystem::path&, const std::vector<Eigen::Matrix<double, dim, 1>>&,                       \
      const std::vector<Eigen::Matrix<double, dim, 1>>&, const std::vector<int>&);                           \
  template json seeds_report<dim>(const std::vector<NeedleRun<dim>>&);                                       \
  template void write_needle_vtp<dim>(                                                                       \
      const std::filesystem::path&, const std::vector<Eigen::Matrix<double, dim, 1>>&,                       \
      const Eigen::Matrix<double, dim, 1>&, const Eigen::Matrix<double, dim, 1>&);
VIM_SIMULATION_OUTPUT(2)
VIM_SIMULATION_OUTPUT(3)
#undef VIM_SIMULATION_OUTPUT

}  // namespace vim::pipeline

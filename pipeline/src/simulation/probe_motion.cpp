// A procedure's probe motion (probe_motion.hpp).
#include "simulation/probe_motion.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "simulation/simulation_output.hpp"

namespace vim::pipeline {

using json = nlohmann::json;

namespace {

// R(θ) about the unit axis a (world), θ in degrees; the identity in 2D (a probe turns only in 3D).
template <int dim>
Eigen::Matrix<double, dim, dim> rotation(const Eigen::Matrix<double, dim, 1>& a, double degrees) {
  if constexpr (dim == 3) {
    return Eigen::AngleAxisd(degrees * M_PI / 180.0, a).toRotationMatrix();
  } else {
    (void)a, (void)degrees;
    return Eigen::Matrix<double, dim, dim>::Identity();
  }
}

// r × f as a 3-vector (2D: the z component alone).
template <int dim>
Eigen::Vector3d moment_of(const Eigen::Matrix<double, dim, 1>& r, const Eigen::Matrix<double, dim, 1>& f) {
  if constexpr (dim == 3) {
    return r.cross(f);
  } else {
    return Eigen::Vector3d(0.0, 0.0, r[0] * f[1] - r[1] * f[0]);
  }
}

template <int dim>
json vector_json(const Eigen::Matrix<double, dim, 1>& v) {
  json j = json::array();
  for (int d = 0; d < dim; ++d) j.push_back(v[d]);
  return j;
}

// The foundation's base at each of its points (frame axes) for the probe's pose: the rigid motion of
// the probe's point there, R(θ)(w − c) + c + t − w with w the point in world coordinates.
template <int dim>
std::vector<Eigen::Matrix<double, dim, 1>> probe_base(const SimulationContext<dim>& ctx) {
  const auto& p = *ctx.probe;
  const Eigen::Matrix<double, dim, dim> R = rotation<dim>(p.axis, p.angle);
  std::vector<Eigen::Matrix<double, dim, 1>> base;
  base.reserve(p.points.size());
  for (const auto& x : p.points) {
    const Eigen::Matrix<double, dim, 1> w = ctx.tf.to_world(x);
    base.push_back(ctx.tf.vector_to_frame(R * (w - p.center) + p.center + p.translation - w));
  }
  return base;
}

// The force of the tissue on the probe, Σ_p k w_p (u(x_p) − b_p) over the foundation's points inside the
// mesh (minus the foundation's forces on the tissue), and its moment about the moved axis centre, in world
// axes, from the model's last solution.
template <int dim>
void probe_load(const SimulationContext<dim>& ctx, const std::vector<Eigen::Matrix<double, dim, 1>>& base,
                ProbeStep<dim>& step) {
  const auto& p = *ctx.probe;
  fem::PointSample info;
  const auto u = ctx.model->sample(p.points, &info);
  const Eigen::Matrix<double, dim, dim> R = rotation<dim>(p.axis, p.angle);
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    if (!info.inside[i]) continue;  // no spring there (fem::VolumeSupport)
    const Eigen::Matrix<double, dim, 1> f =
        ctx.tf.vector_to_world(p.stiffness * p.weights[i] * (u[i] - base[i]));
    step.force += f;
    step.moment += moment_of<dim>(R * (ctx.tf.to_world(p.points[i]) - p.center), f);
  }
}

}  // namespace

template <int dim>
void ProbeMotions<dim>::move(const ProbeMotionSpec& motion, SimulationResult<dim>& res) {
  SimulationContext<dim>& ctx = ctx_;
  std::vector<ProbeStep<dim>>& steps = res.probe_steps;
  auto& probe = *ctx.probe;
  const Vec t0 = probe.translation;
  const double a0 = probe.angle;
  const Vec T = motion.translate.empty() ? Vec::Zero() : spec_vector<dim>(motion.translate);
  std::vector<Vec> points;  // frame: the targets, then the seeds released so far
  for (const auto& t : ctx.sc.targets) points.push_back(ctx.tf.to_frame(spec_vector<dim>(t.position)));
  const std::size_t n_targets = points.size();
  for (const auto& r : ctx.released) points.push_back(r.planned_frame);
  std::vector<Vec> at;
  for (int i = 1; i <= motion.steps; ++i) {
    const double f = static_cast<double>(i) / motion.steps;
    probe.translation = t0 + f * T;
    probe.angle = a0 + f * motion.rotate;
    const std::vector<Vec> base = probe_base<dim>(ctx);
    ctx.model->set_volume_support_base(probe.support, base);
    const fem::Solution<dim> s = ctx.model->solve(ctx.staying, ctx.solver);
    ProbeStep<dim> step;
    step.action = motion.action;
    step.step = i;
    step.translation = probe.translation;
    step.angle = probe.angle;
    probe_load<dim>(ctx, base, step);
    for (const auto& v : s.vertex_displacement)
      step.max_displacement = std::max(step.max_displacement, v.norm());
    // The model's field, with the near fields of the needles left in as a needle step reads it.
    at = points.empty() ? std::vector<Vec>() : ctx.model->sample(points);
    std::size_t first = 0;
    for (const auto& staying : ctx.staying_needles) {
      fem::Solution<dim> rows;
      rows.point_force.assign(s.point_force.begin() + static_cast<long>(first),
                              s.point_force.begin() + static_cast<long>(first + staying.rows));
      at = staying.coupling->tissue_displacements(points, std::move(at), staying.state, rows);
      first += staying.rows;
    }
    for (auto& v : at) v = ctx.tf.vector_to_world(v);
    step.target_displacement.assign(at.begin(), at.begin() + static_cast<long>(n_targets));
    steps.push_back(step);
    const int k = static_cast<int>(steps.size());  // numbered over all probe steps
    if (writes_steps(ctx.opt) && ctx.sc.output_every > 0 &&
        (k % ctx.sc.output_every == 0 || i == motion.steps))
      output_step(k, s, std::vector<Vec>(at.begin() + static_cast<long>(n_targets), at.end()));
  }
  // The seeds released so far end where the tissue now holds them (their needles' runs are over; a later
  // needle is withdrawn again and leaves this state, a later motion updates it).
  std::size_t j = n_targets;
  for (auto& run : res.needles)
    for (auto& seed : run.seeds)
      if (seed.release_step >= 0 && j < at.size()) seed.rest_displacement = at[j++];
}

// The step file of probe step k and, in a procedure, the released seeds where the tissue holds them (u:
// the tissue's displacement at their planned positions, world).
template <int dim>
void ProbeMotions<dim>::output_step(int k, const fem::Solution<dim>& s, const std::vector<Vec>& u) {
  const std::string file = "steps/" + step_file(k, ctx_.opt.mpi_ranks);
  write_step_vtu<dim>(ctx_, "probe/" + file, &s);
  pvd_.push_back({static_cast<double>(k), file});
  if (!ctx_.sc.procedure || !ctx_.opt.output_file) return;
  std::vector<Vec> position, planned;
  std::vector<int> needle;
  for (std::size_t j = 0; j < ctx_.released.size(); ++j) {
    position.push_back(ctx_.released[j].material + u[j]);
    planned.push_back(ctx_.released[j].planned);
    needle.push_back(ctx_.released[j].needle);
  }
  char name[32];
  std::snprintf(name, sizeof name, "steps/seeds_%04d.vtu", k);
  write_seed_points<dim>(ctx_.opt.output_file(std::string("probe/") + name), position, planned, needle);
  seeds_pvd_.push_back({static_cast<double>(k), name});
}

namespace {

// probe.csv: one row per probe step (action, step, translation, angle, force, moment, targets).
template <int dim>
void write_probe_csv(const std::filesystem::path& path, const std::vector<ProbeStep<dim>>& steps,
                     const Scenario& sc) {
  write_text_atomically(path, [&](std::ostream& o) {
    const char* axes = "xyz";
    o << "action,step";
    for (int d = 0; d < dim; ++d) o << ",translation_" << axes[d];
    o << ",angle";
    for (int d = 0; d < dim; ++d) o << ",force_" << axes[d];
    for (int d = 0; d < 3; ++d) o << ",moment_" << axes[d];
    for (const auto& t : sc.targets) {
      for (int d = 0; d < dim; ++d) o << "," << t.name << "_d" << axes[d];
      o << "," << t.name << "_norm";
    }
    o << "\n" << std::setprecision(10);
    for (const auto& s : steps) {
      o << s.action << "," << s.step;
      for (int d = 0; d < dim; ++d) o << "," << s.translation[d];
      o << "," << s.angle;
      for (int d = 0; d < dim; ++d) o << "," << s.force[d];
      for (int d = 0; d < 3; ++d) o << "," << s.moment[d];
      for (const auto& u : s.target_displacement) {
        for (int d = 0; d < dim; ++d) o << "," << u[d];
        o << "," << u.norm();
      }
      o << "\n";
    }
  });
}

// report.json's simulation.probe.
template <int dim>
json probe_report(const SimulationContext<dim>& ctx, const std::vector<ProbeStep<dim>>& steps) {
  const ProbeSpec& spec = *ctx.sc.probe;
  json motions = json::array();
  for (const auto& m : spec.motions) {
    json j = {{"action", m.action}, {"line", m.line}, {"steps", m.steps}};
    if (m.translate.empty())
      j["rotate"] = m.rotate;
    else
      j["translate"] = m.translate;
    motions.push_back(j);
  }
  json per = json::array();
  for (const auto& s : steps)
    per.push_back({{"action", s.action},
                   {"step", s.step},
                   {"translation", vector_json<dim>(s.translation)},
                   {"angle", s.angle},
                   {"force", vector_json<dim>(s.force)},
                   {"moment", {s.moment[0], s.moment[1], s.moment[2]}},
                   {"max_displacement", s.max_displacement}});
  json rep = {{"region", spec.hold.region.describe()},
              {"stiffness", spec.hold.support_stiffness},
              {"points", ctx.probe->points.size()},
              {"motions", motions},
              {"steps", per},
              {"file", "probe.csv"}};
  if (!steps.empty()) rep["final"] = per.back();
  return rep;
}

}  // namespace

template <int dim>
json ProbeMotions<dim>::finish(const std::vector<ProbeStep<dim>>& steps) const {
  if (ctx_.opt.output_file && !steps.empty()) {
    write_probe_csv<dim>(ctx_.opt.output_file("probe.csv"), steps, ctx_.sc);
    if (!pvd_.empty()) write_pvd(ctx_.opt.output_file("probe/simulation.pvd"), pvd_);
    if (!seeds_pvd_.empty()) write_pvd(ctx_.opt.output_file("probe/seeds.pvd"), seeds_pvd_);
  }
  return probe_report<dim>(ctx_, steps);
}

template class ProbeMotions<2>;
template class ProbeMotions<3>;

}  // namespace vim::pipeline

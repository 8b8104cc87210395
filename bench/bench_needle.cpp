// Needle steps per second on the condensed fast path (ElasticModel::precompute before stepping: K
// factorised once, every shaft row's column K⁻¹cᵀ in one batch; each step is dense work on the active
// rows) against the monolithic saddle-point solve per step (ElasticModel::solve_monolithic) in the same
// run, on Kuhn-grid blocks of ~1k and ~10k nodes, P1 and P2, stick friction (or the law given).
// Prints the precomputation time, steps/s (mean, median, p99 of the steps alone) and the ratio; asserts
// nothing.
//   bench_needle [--steps N] [--mono-steps N] [--mono-max-dofs N] [--friction stick|stick-slip]
//                [--sizes 1k,10k] [--degrees 1,2] [--solver auto|direct|amg] [--haptic 0|1]
//                [--cutting-force F] [--flexible 0|1]
// --haptic 1 adds a table of vim::needle::HapticNeedle (the real-time needle in a condensed region) on the
// same blocks; --cutting-force F (mN, default 0) gives its tip that cutting force (the tip bearing).
// --flexible 1 adds the flexible needle (an 18 G steel tube, needle.flexible {E 2e8 kPa, d_i 0.84 mm},
// a 30° bevel) to each table: its steps per second (precomputation excluded) and its time per step as a
// ratio to the rigid needle's of the same run (the CLI's: the same scenario without flexible and bevel;
// the real-time needle's: the same calls stepped by the tip, the flexible one by its base held at the
// entry as a template holds it). The
// monolithic solve of a ~10k-node P2 block factorises a ~280k-DoF saddle-point matrix per step (minutes and
// many GB): it runs only up to --mono-max-dofs DoFs (default 100000).
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>
#include <vim/initial_mesh.hpp>
#include <vim/needle/haptic_needle.hpp>
#include <vim/needle/needle_band.hpp>
#include <vim/pipeline/common/progress.hpp>
#include <vim/pipeline/simulation/simulation.hpp>

using namespace vim;
using namespace vim::pipeline;

namespace {

MeshModel<3> block(int n_xy, int n_z) {
  MeshModel<3> m;
  m.mesh =
      regular_grid_mesh<3>(Eigen::Vector3d(-20, -20, 0), Eigen::Vector3d(20, 20, 60), {{n_xy, n_xy, n_z}});
  m.values.assign(m.mesh.n_cells(), ElementValue{1, 15.0, 0.0});
  return m;
}

struct Timing {
  double precompute = 0.0, mean = 0.0, median = 0.0, p99 = 0.0;  // seconds per step for the last three
  int points = 0;
  unsigned dofs = 0;
  double force = 0.0;
  double cpu_mean = 0.0;  // haptic: thread CPU seconds per call (robust to a loaded machine)
};

// The 18 G steel needle's tube (ASM Handbook vol. 1: steel 200 GPa = 2e8 kPa; 18 G: 1.27 / 0.84 mm) and
// a 30° bevel (assumed).
constexpr double kSteelModulus = 2.0e8, kInnerDiameter = 0.84, kBevelAngle = 30.0;

Timing time_run(const MeshModel<3>& model, unsigned degree, int steps, const std::string& friction,
                const std::string& solver, bool monolithic, bool flexible = false) {
  std::string law = friction == "stick-slip" ? ", friction: {model: stick-slip, max_shear_per_length: 0.5}"
                                             : ", friction: {model: stick}";
  if (flexible)
    law += ", flexible: {youngs_modulus: " + std::to_string(kSteelModulus) +
           ", inner_diameter: " + std::to_string(kInnerDiameter) +
           "}, bevel: {angle: " + std::to_string(kBevelAngle) + ", side: [1, 0, 0]}";
  const std::string y =
      "material: {poisson_ratio: 0.45}\n"
      "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
      "needle: {entry: [0.3, -0.2, 0], direction: [0, 0, 1], depth: 40, steps: " +
      std::to_string(steps) + ", diameter: 1.27" + law +
      "}\n"
      "targets: [{name: t, position: [0, 0, 45]}]\noutput: {every: 0}\nsolver: {type: " +
      solver + "}\n";
  SimulationOptions o;
  o.progress = false;
  o.monolithic = monolithic;
  o.step_fields = false;  // forces and targets per step; the field only at the last step (the real-time rate)
  o.degree = degree;
  NeedleSimulation<3> sim(model, parse_scenario_text(y, 3, "bench"), o);
  const auto res = sim.run();
  const auto& r = res.needles[0];
  Timing t;
  t.precompute = r.precompute_seconds;
  std::vector<double> st(r.step_seconds.begin() + 1, r.step_seconds.end());
  t.mean = r.stepping_seconds / steps;
  std::sort(st.begin(), st.end());
  t.median = st[st.size() / 2];
  t.p99 = st[std::min(st.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(st.size())))];
  t.points = r.active_points.back();
  t.dofs = r.stats.n_dofs;
  t.force = r.axial_force.back();
  return t;
}

// vim::needle::HapticNeedle on the same block (its model and conditions from a NeedleSimulation that does not
// run): the default band (as the CLI's), the region a cylinder of radius R + h around the path, one probe
// (the target), stick-slip at 0.5 mN/mm (the registered law), the tip advanced along the path in `steps`
// calls. Returns the precomputation (s), the region's DoFs and the per-call times (wall, and the thread's
// CPU time, which time slices taken by other processes do not inflate).
Timing time_haptic(const MeshModel<3>& model, unsigned degree, double h, int steps, double cutting_force,
                   bool flexible = false) {
  const std::string y =
      "material: {poisson_ratio: 0.45}\n"
      "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
      "needle: {entry: [0.3, -0.2, 0], direction: [0, 0, 1], depth: 40, steps: 1, diameter: 1.27, friction: "
      "{model: stick}}\n";
  SimulationOptions so;
  so.progress = false;
  so.degree = degree;
  NeedleSimulation<3> sim(model, parse_scenario_text(y, 3, "bench"), so);
  vim::needle::HapticNeedle::Options o;
  o.radius = 0.635;
  o.element_size = h;  // the default band, as the CLI's
  o.spacing = h;
  o.friction.law = "stick-slip";
  o.friction.max_shear_per_length = 0.5;
  o.friction.cutting_force = cutting_force;
  if (flexible) {
    o.flexible = vim::needle::FlexibleNeedle{kSteelModulus, 0.0, kInnerDiameter, 0.0};
    o.bevel_angle = kBevelAngle;
  }
  const double reach = vim::needle::default_coupling_radius(o.radius, h, degree) + h;
  const fem::Region<3> region{
      "path", [reach](const fem::Vec<3>& x) { return std::hypot(x[0] - 0.3, x[1] + 0.2) < reach; }};
  const auto t0 = std::chrono::steady_clock::now();
  vim::needle::HapticNeedle needle(sim.model(), region, {fem::Vec<3>(0, 0, 45)}, o);
  Timing t;
  t.precompute = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  t.dofs = static_cast<unsigned>(needle.region_dofs());
  std::vector<double> st;
  double total = 0.0, cpu = 0.0;
  const auto cpu_now = [] {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  };
  for (int k = 0; k <= steps; ++k) {
    const double c0 = cpu_now();
    const auto a = std::chrono::steady_clock::now();
    const fem::Vec<3> tip(0.3, -0.2, 40.0 * k / steps), direction(0, 0, 1);
    const auto& r = flexible
                        ? needle.step({tip - tip[2] * direction, direction, tip[2], fem::Vec<3>(1, 0, 0)})
                        : needle.step(tip, direction);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
    const double dc = cpu_now() - c0;
    if (k == 0) continue;
    st.push_back(dt), total += dt, cpu += dc;
    t.points = static_cast<int>(r.stations);
    t.force = -r.force[2];
  }
  t.mean = total / steps;
  t.cpu_mean = cpu / steps;
  std::sort(st.begin(), st.end());
  t.median = st[st.size() / 2];
  t.p99 = st[std::min(st.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(st.size())))];
  return t;
}

// A flexible needle's row under its rigid one's: steps per second (wall; CPU for the real-time needle),
// median and p99, and its mean time per step over the rigid needle's.
void print_flexible(const char* name, const Timing& flex, const Timing& rigid) {
  const bool cpu = flex.cpu_mean > 0.0;
  std::printf(
      "%10s: %10.0f st/s%s, median %.3f ms, p99 %.3f ms, time per step x%.2f of the rigid needle's, "
      "force %.5g\n",
      name, 1.0 / (cpu ? flex.cpu_mean : flex.mean), cpu ? " (cpu)" : "", 1e3 * flex.median, 1e3 * flex.p99,
      cpu ? flex.cpu_mean / rigid.cpu_mean : flex.mean / rigid.mean, flex.force);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t a = 0;
  while (a <= s.size()) {
    const std::size_t b = std::min(s.find(',', a), s.size());
    out.push_back(s.substr(a, b - a));
    a = b + 1;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);  // Trilinos (AMG) needs MPI even on one rank
  Log::set_verbosity(Verbosity::quiet);
  int steps = 200, mono_steps = 5;
  unsigned mono_max_dofs = 100000;
  std::string friction = "stick", sizes = "1k,10k", degrees = "1,2", solver = "auto";
  bool haptic = false, flexible = false;
  double cutting_force = 0.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--steps")
      steps = std::atoi(v.c_str());
    else if (k == "--mono-steps")
      mono_steps = std::atoi(v.c_str());
    else if (k == "--mono-max-dofs")
      mono_max_dofs = static_cast<unsigned>(std::atol(v.c_str()));
    else if (k == "--friction")
      friction = v;
    else if (k == "--sizes")
      sizes = v;
    else if (k == "--degrees")
      degrees = v;
    else if (k == "--solver")
      solver = v;
    else if (k == "--haptic")
      haptic = v == "1";
    else if (k == "--flexible")
      flexible = v == "1";
    else if (k == "--cutting-force")
      cutting_force = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "bench_needle: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  std::printf("needle steps, %s friction, %d steps over 40 mm (monolithic: %d steps)\n", friction.c_str(),
              steps, mono_steps);
  std::printf("%6s %3s %8s %7s %11s %10s %10s %10s %11s %8s %10s\n", "nodes", "P", "DoFs", "points",
              "precomp_s", "mean_st/s", "median_ms", "p99_ms", "mono_st/s", "ratio", "force");
  for (const std::string& size : split(sizes)) {
    const MeshModel<3> m = size == "10k" ? block(17, 35) : block(8, 16);
    for (const std::string& deg : split(degrees)) {
      const auto degree = static_cast<unsigned>(std::atoi(deg.c_str()));
      const Timing fast = time_run(m, degree, steps, friction, solver, false);
      Timing mono;
      const bool run_mono = fast.dofs <= mono_max_dofs && mono_steps > 0;
      if (run_mono) mono = time_run(m, degree, mono_steps, friction, solver, true);
      char mono_rate[32] = "-", ratio[32] = "-";
      if (run_mono) {
        std::snprintf(mono_rate, sizeof mono_rate, "%.2f", 1.0 / mono.mean);
        std::snprintf(ratio, sizeof ratio, "%.0f", mono.mean / fast.mean);
      }
      std::printf("%6zu %3u %8u %7d %11.2f %10.0f %10.3f %10.3f %11s %8s %10.5g\n", m.mesh.n_points(), degree,
                  fast.dofs, fast.points, fast.precompute, 1.0 / fast.mean, 1e3 * fast.median, 1e3 * fast.p99,
                  mono_rate, ratio, fast.force);
      if (flexible) {
        const Timing flex = time_run(m, degree, steps, friction, solver, false, true);
        print_flexible("flexible", flex, fast);
      }
      std::fflush(stdout);
    }
  }
  if (haptic) {
    std::printf(
        "\nreal-time needle (vim::needle::HapticNeedle), stick-slip, cutting force %g mN, %d calls over 40 "
        "mm\n",
        cutting_force, steps);
    std::printf("%6s %3s %11s %9s %11s %10s %10s %10s %10s %10s\n", "nodes", "P", "region_DoFs", "stations",
                "precomp_s", "mean_st/s", "cpu_st/s", "median_ms", "p99_ms", "force");
    for (const std::string& size : split(sizes)) {
      const bool big = size == "10k";
      const MeshModel<3> m = big ? block(17, 35) : block(8, 16);
      const double h = big ? 40.0 / 16.0 : 40.0 / 7.0;  // grid edge
      for (const std::string& deg : split(degrees)) {
        const auto degree = static_cast<unsigned>(std::atoi(deg.c_str()));
        const Timing t = time_haptic(m, degree, h, steps, cutting_force);
        std::printf("%6zu %3u %11u %9d %11.2f %10.0f %10.0f %10.3f %10.3f %10.5g\n", m.mesh.n_points(),
                    degree, t.dofs, t.points, t.precompute, 1.0 / t.mean, 1.0 / t.cpu_mean, 1e3 * t.median,
                    1e3 * t.p99, t.force);
        if (flexible) print_flexible("flexible", time_haptic(m, degree, h, steps, cutting_force, true), t);
        std::fflush(stdout);
      }
    }
  }
  MPI_Finalize();
  return 0;
}

// Needle steps per second: the condensed fast path (K factorised once, cached K⁻¹Cᵀ columns) vs a
// monolithic saddle-point solve per step, on P1 Kuhn-grid blocks of ~1k and ~10k nodes
// (target: >= 500 steps/s at ~1k nodes). Prints the ratio; asserts nothing.
//   bench_needle [steps] [cached]   ("cached": skip the monolithic baseline, e.g. for profiling)
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/progress.hpp>
#include <vim/pipeline/simulation.hpp>

#include <mpi.h>

#include <chrono>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <vector>
#include <string>

using namespace vim;
using namespace vim::pipeline;

namespace {

MeshModel<3> block(int n_xy, int n_z) {
  MeshModel<3> m;
  m.mesh = regular_grid_mesh<3>(Eigen::Vector3d(-20, -20, 0), Eigen::Vector3d(20, 20, 60), {{n_xy, n_xy, n_z}});
  m.values.assign(m.mesh.n_cells(), ElementValue{1, 15.0, 0.0});
  return m;
}

struct Timing {
  double steps_per_second = 0.0, steady = 0.0, solve_fraction = 0.0, force = 0.0, median_step = 0.0;
  int points = 0;
};

Timing time_run(const MeshModel<3>& model, int steps, bool monolithic) {
  const std::string y = "material: {poisson_ratio: 0.45}\n"
                        "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
                        "needle: {entry: [0.3, -0.2, 0], direction: [0, 0, 1], depth: 40, steps: " +
                        std::to_string(steps) + ", diameter: 1.27, friction: {model: stick}}\n"
                        "targets: [{name: t, position: [0, 0, 45]}]\noutput: {every: 0}\n";
  SimulationOptions o;
  o.progress = false;
  o.monolithic = monolithic;
  NeedleSimulation<3> sim(model, parse_scenario_text(y, 3, "bench"), o);
  const auto t0 = std::chrono::steady_clock::now();
  const auto res = sim.run();
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Timing t;
  const auto& r = res.needles[0];
  t.steps_per_second = steps / total;
  t.force = r.axial_force.back();
  t.points = r.active_points.back();
  double later = 0.0;  // steps 2..n: the factorisation is reused
  for (std::size_t k = 2; k < r.step_seconds.size(); ++k) later += r.step_seconds[k];
  t.steady = later > 0.0 ? (r.step_seconds.size() - 2) / later : 0.0;
  t.solve_fraction = r.solve_seconds / total;
  std::vector<double> st(r.step_seconds.begin() + 1, r.step_seconds.end());
  std::sort(st.begin(), st.end());
  t.median_step = st.empty() ? 0.0 : st[st.size() / 2];
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);  // Trilinos (AMG) needs MPI even on one rank
  Log::set_verbosity(Verbosity::quiet);
  const int steps = argc > 1 ? std::atoi(argv[1]) : 100;
  const bool baseline = !(argc > 2 && std::string(argv[2]) == "cached");
  std::printf("needle steps/s, P1, stick, %d steps over 40 mm (includes assembly + factorisation)\n", steps);
  std::printf("%8s %8s %12s %12s %12s %12s %8s %8s %12s %12s\n", "nodes", "points", "cached", "cached(2..)", "monolithic",
              "mono(2..)", "ratio", "solve%", "median_ms", "force");
  for (const auto& [nxy, nz] : {std::pair{8, 16}, std::pair{17, 35}}) {
    const MeshModel<3> m = block(nxy, nz);
    const Timing fast = time_run(m, steps, false);
    const int mono_steps = m.mesh.n_points() > 5000 ? std::max(4, steps / 10) : steps;
    const Timing mono = baseline ? time_run(m, mono_steps, true) : Timing{1, 1, 0, 0, 0, 0};
    std::printf("%8zu %8d %12.1f %12.1f %12.2f %12.2f %8.1f %8.0f %12.3f %12.5g\n", m.mesh.n_points(), fast.points,
                fast.steps_per_second, fast.steady, mono.steps_per_second, mono.steady, fast.steady / mono.steady,
                100.0 * fast.solve_fraction, 1e3 * fast.median_step, fast.force);
  }
  MPI_Finalize();
  return 0;
}

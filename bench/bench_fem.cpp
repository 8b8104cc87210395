// FEM benchmark (not a test): assembly + solve times and peak memory (VmHWM) for P1 models on Kuhn
// cube meshes, the Q1 voxel reference, and needle-style steps (cached Schur fast path vs monolithic).
//   bench_fem                      serial: P1 ~10k and ~100k DoFs (direct and AMG), needle steps
//   bench_fem --p1 68              one P1 model with 68³·6 tets (~1M DoFs; AMG)
//   bench_fem --p1-2d 300          2D P1, 300²·2 triangles (~180k DoFs), direct and AMG
//   mpirun -np 2 bench_fem --mpi --p1 68 --voxel 100    the same on 2 ranks (solve_distributed)
#include "../tests/fem/box_mesh.hpp"

#include <vim/fem/distributed.hpp>
#include <vim/fem/elasticity.hpp>

#include <deal.II/base/mpi.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

using namespace vim;
using namespace vim::fem;

namespace {
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double vm_hwm_gb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / (1024.0 * 1024.0);
  return 0;
}
std::vector<double> moduli(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(1.0, 10.0);
  std::vector<double> E(n);
  for (auto& e : E) e = U(rng);
  return E;
}
template <int dim>
void conditions(ElasticModel<dim>& model) {
  DirichletBC<3> fixed;
  fixed.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, false, 1e-9);
  model.add_dirichlet(fixed);
  SurfaceLoad<3> load;
  load.region = box_face_region<3>(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), 2, true, 1e-9);
  load.pressure = 1.0;
  model.add_surface_load(load);
}

void row(const char* what, int ranks, const Solution<3>& s, double build, double total, MPI_Comm comm) {
  const double hwm = vm_hwm_gb();
  const double hwm_max = dealii::Utilities::MPI::max(hwm, comm), hwm_sum = dealii::Utilities::MPI::sum(hwm, comm);
  if (dealii::Utilities::MPI::this_mpi_process(comm) == 0)
    std::printf("| %-22s | %5d | %9u | %-22s | %5u | %8.2f | %8.2f | %8.2f | %8.2f | %8.2f | %8.2f | %6.2f / %6.2f |\n",
                what, ranks, s.stats.n_dofs, s.stats.method.c_str(), s.stats.iterations, build, s.stats.setup_seconds,
                s.stats.assemble_seconds - s.stats.setup_seconds, s.stats.precondition_seconds,
                s.stats.solve_seconds - s.stats.precondition_seconds, total, hwm_max, hwm_sum);
  std::fflush(stdout);
}

void header(MPI_Comm comm) {
  if (dealii::Utilities::MPI::this_mpi_process(comm) != 0) return;
  // model s: building the ElasticModel (every rank); setup s: distributed mesh + DoFs (MPI only);
  // prec s: UMFPACK factorisation / AMG set-up; solve s: back-substitution / CG after it.
  std::printf("| %-22s | %5s | %9s | %-22s | %5s | %8s | %8s | %8s | %8s | %8s | %8s | %15s |\n", "model", "ranks", "DoFs",
              "method", "iter", "model s", "setup s", "assem s", "prec s", "solve s", "total s", "VmHWM GB max/sum");
  std::printf("|%s|\n", std::string(183, '-').c_str());
}

void p1_model(int n, SolverOptions::Type type, bool mpi, MPI_Comm comm) {
  const double t0 = now();
  const auto mesh = test::kuhn_box<3>({{n, n, n}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, moduli(mesh.n_cells()), 0.45, 1);
  conditions(model);
  const double build = now() - t0;
  SolverOptions opt;
  opt.type = type;
  opt.tolerance = 1e-8;
  const Solution<3> s = mpi ? solve_distributed(model, comm, opt) : model.solve({}, opt);
  const std::string name = "P1 Kuhn " + std::to_string(n) + "^3";
  row(name.c_str(), dealii::Utilities::MPI::n_mpi_processes(comm), s, build, now() - t0, comm);
}

// 2D P1 (direct vs AMG), for the 2D direct_limit: unit square, bottom fixed, pressure on top.
void p1_model_2d(int n, SolverOptions::Type type) {
  const double t0 = now();
  const auto mesh = test::kuhn_box<2>({{n, n}}, {{0, 0}}, {{1, 1}});
  ElasticModel<2> model(mesh, moduli(mesh.n_cells()), 0.45, 1);
  DirichletBC<2> fixed;
  fixed.region = box_face_region<2>(Vec<2>(0, 0), Vec<2>(1, 1), 1, false, 1e-9);
  model.add_dirichlet(fixed);
  SurfaceLoad<2> load;
  load.region = box_face_region<2>(Vec<2>(0, 0), Vec<2>(1, 1), 1, true, 1e-9);
  load.pressure = 1.0;
  model.add_surface_load(load);
  const double build = now() - t0;
  SolverOptions opt;
  opt.type = type;
  opt.tolerance = 1e-8;
  const auto s = model.solve({}, opt);
  std::printf("| P1 2D Kuhn %-11s |     1 | %9u | %-22s | %5u | %8.2f | %8.2f | %8.2f | %8.2f | %8.2f | %8.2f | %6.2f          |\n",
              (std::to_string(n) + "^2").c_str(), s.stats.n_dofs, s.stats.method.c_str(), s.stats.iterations, build, 0.0,
              s.stats.assemble_seconds, s.stats.precondition_seconds, s.stats.solve_seconds - s.stats.precondition_seconds,
              now() - t0, vm_hwm_gb());
  std::fflush(stdout);
}

void voxel_model(int n, bool mpi, MPI_Comm comm) {
  const double t0 = now();
  auto model = ElasticModel<3>::voxel_grid({{n, n, n}}, Vec<3>(0, 0, 0), Vec<3>(1, 1, 1),
                                           moduli(static_cast<std::size_t>(n) * n * n), 0.45);
  conditions(model);
  const double build = now() - t0;
  SolverOptions opt;
  opt.type = SolverOptions::Type::amg;
  opt.tolerance = 1e-8;
  const Solution<3> s = mpi ? solve_distributed(model, comm, opt) : model.solve({}, opt);
  const std::string name = "Q1 voxel " + std::to_string(n) + "^3";
  row(name.c_str(), dealii::Utilities::MPI::n_mpi_processes(comm), s, build, now() - t0, comm);
}

// Needle-like stepping: each step adds one stuck point on a line and moves all of them.
void needle_steps(int n, int steps) {
  const auto mesh = test::kuhn_box<3>({{n, n, n}}, {{0, 0, 0}}, {{1, 1, 1}});
  ElasticModel<3> model(mesh, moduli(mesh.n_cells()), 0.45, 1);
  conditions(model);
  model.solve();  // factorise once (not timed per step)
  auto step_points = [&](int s) {
    std::vector<PointConstraint<3>> pts;
    for (int k = 0; k <= s; ++k)
      pts.push_back({Vec<3>(0.503, 0.497, 0.95 - 0.8 * k / steps), Vec<3>(0, 0, -0.002 * (s + 1))});
    return pts;
  };
  double t = now();
  for (int s = 0; s < steps; ++s) model.solve(step_points(s));
  const double fast = now() - t;
  double mono = 1e-300;
  if (!std::getenv("BENCH_FAST_ONLY")) {
    t = now();
    for (int s = 0; s < steps; ++s) model.solve_monolithic(step_points(s));
    mono = now() - t;
  }
  std::printf("needle steps, P1 %zu nodes (%u DoFs), %d steps: cached Schur %.1f steps/s, monolithic %.1f steps/s, "
              "ratio %.1fx\n",
              mesh.n_points(), model.n_dofs(), steps, steps / fast, steps / mono, mono / fast);
}
}  // namespace

int main(int argc, char** argv) {
  dealii::Utilities::MPI::MPI_InitFinalize init(argc, argv, 1);
  MPI_Comm comm = MPI_COMM_WORLD;
  bool mpi = false;
  std::vector<int> p1, p1_2d, voxel, needle;
  bool defaults = true, amg_too = true;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--mpi")) mpi = true;
    else if (!std::strcmp(argv[i], "--p1") && i + 1 < argc) p1.push_back(std::atoi(argv[++i])), defaults = false;
    else if (!std::strcmp(argv[i], "--p1-2d") && i + 1 < argc) p1_2d.push_back(std::atoi(argv[++i])), defaults = false;
    else if (!std::strcmp(argv[i], "--voxel") && i + 1 < argc) voxel.push_back(std::atoi(argv[++i])), defaults = false;
    else if (!std::strcmp(argv[i], "--no-amg")) amg_too = false;
    else if (!std::strcmp(argv[i], "--needle") && i + 1 < argc) needle.push_back(std::atoi(argv[++i])), defaults = false;
    else {
      std::fprintf(stderr, "usage: bench_fem [--mpi] [--p1 N]... [--p1-2d N]... [--voxel N]... [--needle N]... [--no-amg]\n");
      return 2;
    }
  }
  if (defaults) p1 = {14, 31};
  header(comm);
  for (int n : p1) {
    if (mpi) {
      p1_model(n, SolverOptions::Type::amg, true, comm);
    } else {
      const long dofs = 3L * (n + 1) * (n + 1) * (n + 1);
      if (dofs <= 200000) p1_model(n, SolverOptions::Type::direct, false, comm);
      if (amg_too || dofs > 200000) p1_model(n, SolverOptions::Type::amg, false, comm);
    }
  }
  for (int n : p1_2d) {
    p1_model_2d(n, SolverOptions::Type::direct);
    p1_model_2d(n, SolverOptions::Type::amg);
  }
  for (int n : voxel) voxel_model(n, mpi, comm);
  for (int n : needle) needle_steps(n, 40);
  if (defaults && !mpi) {
    needle_steps(9, 40);   // ~1k nodes
    needle_steps(21, 20);  // ~10k nodes
  }
  return 0;
}

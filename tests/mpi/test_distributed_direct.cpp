// The distributed direct solves on 2 ranks (MUMPS's factorisation of the distributed K, kept for every
// right-hand side) against the distributed CG + AMG solves and the serial Schur solve (CHOLMOD) of the
// same needle rows; the automatic choice under a memory limit; a direct solve that would not fit.
#include <deal.II/base/mpi.h>
#include <gtest/gtest.h>

#include <random>
#include <vim/fem/distributed.hpp>
#include <vim/fem/elasticity.hpp>

#include "../fem/box_mesh.hpp"
#include "box_conditions.hpp"

using namespace vim;
using namespace vim::fem;

namespace {

// A P2 Kuhn cube with random moduli (the same on every rank), held at x = 0, pushed and loaded at x = 1.
ElasticModel<3> needle_model(bool spread) {
  const auto mesh = test::kuhn_box<3>({{4, 4, 4}}, {{0, 0, 0}}, {{1, 1, 1}});
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> U(1.0, 8.0);
  std::vector<double> E(mesh.n_cells());
  for (auto& e : E) e = U(rng);
  ElasticModel<3> model(mesh, E, 0.35, 2);
  test::hold_and_push(model, true, -0.01);
  SurfaceLoad<3> load;
  load.region = box_face_region<3>(Vec<3>::Zero(), Vec<3>::Ones(), 2, true, 1e-9);
  load.pressure = 0.3;
  model.add_surface_load(load);
  if (spread) distribute_solves(model, MPI_COMM_WORLD);
  return model;
}

// The needle's rows: the tip held at a displacement, a band of 8 samples with a series compliance.
std::vector<PointConstraint<3>> needle_rows(double shift) {
  PointConstraint<3> tip(Vec<3>(0.43 + shift, 0.51, 0.47), Vec<3>(0.01, -0.02, 0.005));
  PointConstraint<3> band(Vec<3>(0.3, 0.52, 0.5), Vec<3>(0.0, 0.01, 0.0));
  for (int q = 0; q < 8; ++q) {
    const double a = 0.25 * M_PI * q;
    band.offsets.push_back(Vec<3>(0.0, 0.1 * std::cos(a), 0.1 * std::sin(a)));
    band.weights.push_back(1.0);
  }
  band.compliance = Vec<3>(0.02, 0.03, 0.03);
  return {tip, band};
}

SolverOptions options(SolverOptions::Type type, double max_memory = 0.0) {
  SolverOptions o;
  o.type = type;
  o.tolerance = 1e-13;
  o.max_memory = max_memory;
  return o;
}

// |sol − ref| / |ref| over the vertex displacements and the point forces.
double relative_difference(const Solution<3>& ref, const Solution<3>& sol) {
  double d = 0, s = 0;
  for (std::size_t v = 0; v < ref.vertex_displacement.size(); ++v)
    d = std::max(d, (sol.vertex_displacement[v] - ref.vertex_displacement[v]).norm()),
    s = std::max(s, ref.vertex_displacement[v].norm());
  double r = d / s;
  for (std::size_t k = 0; k < ref.point_force.size(); ++k)
    r = std::max(r, (sol.point_force[k] - ref.point_force[k]).norm() / ref.point_force[k].norm());
  return r;
}

std::string on_ranks(const std::string& method) {
  return method + " (mpi, " + std::to_string(dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD)) +
         " ranks)";
}

}  // namespace

// The load solution and the needle rows' columns by MUMPS (one factorisation, back-substitutions), by
// CG + AMG over the ranks and serially by CHOLMOD: displacements and point forces agree to 1e-8, for
// the load alone and with the rows, twice (the second pass moves the tip: new columns from the kept
// factor).
TEST(DistributedDirect, NeedleRowsAgreeWithIterativeAndSerialSolves) {
  ElasticModel<3> serial = needle_model(false), direct = needle_model(true), iterative = needle_model(true);
  for (int pass = 0; pass < 3; ++pass) {
    const auto rows = pass == 0 ? std::vector<PointConstraint<3>>{} : needle_rows(0.05 * pass);
    const Solution<3> ref = serial.solve(rows, options(SolverOptions::Type::direct));
    const Solution<3> d = direct.solve(rows, options(SolverOptions::Type::direct));
    const Solution<3> i = iterative.solve(rows, options(SolverOptions::Type::amg));
    EXPECT_EQ(ref.stats.method, "cholmod");
    EXPECT_EQ(d.stats.method, on_ranks("mumps"));
    EXPECT_EQ(i.stats.method, on_ranks("cg+amg"));
    EXPECT_NE(d.stats.reason.find("MUMPS estimates"), std::string::npos) << d.stats.reason;
    EXPECT_LT(relative_difference(ref, d), 1e-8) << "pass " << pass;
    EXPECT_LT(relative_difference(ref, i), 1e-8) << "pass " << pass;
    EXPECT_LT(relative_difference(d, i), 1e-8) << "pass " << pass;
    EXPECT_NEAR(d.strain_energy, ref.strain_energy, 1e-8 * ref.strain_energy);
  }
}

// solver.type auto: MUMPS without a limit, CG + AMG when its estimate exceeds a small limit (saying so),
// the same solution either way.
TEST(DistributedDirect, AutomaticFallsBackToAmgUnderASmallMemoryLimit) {
  ElasticModel<3> roomy = needle_model(true), tight = needle_model(true);
  const auto rows = needle_rows(0.0);
  const Solution<3> a = roomy.solve(rows, options(SolverOptions::Type::automatic));
  const Solution<3> b = tight.solve(rows, options(SolverOptions::Type::automatic, 1e5));
  EXPECT_EQ(a.stats.method, on_ranks("mumps"));
  EXPECT_EQ(b.stats.method, on_ranks("cg+amg"));
  EXPECT_NE(a.stats.reason.find("no memory limit"), std::string::npos) << a.stats.reason;
  EXPECT_NE(b.stats.reason.find("above the limit of 0 MB per rank: CG + AMG"), std::string::npos)
      << b.stats.reason;
  EXPECT_LT(relative_difference(a, b), 1e-8);
}

// solver.type direct with an estimate above the limit: one line with the estimate, on every rank.
TEST(DistributedDirect, DirectAboveTheMemoryLimitIsRefusedWithTheEstimate) {
  ElasticModel<3> model = needle_model(true);
  try {
    model.solve(needle_rows(0.0), options(SolverOptions::Type::direct, 1e5));
    ADD_FAILURE() << "no error for a factorisation above the limit";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("solver.type direct: MUMPS estimates "), std::string::npos) << what;
    EXPECT_NE(what.find("above the limit of 0 MB per rank"), std::string::npos) << what;
  }
}

// The finite-radius needle coupling (vim/needle/needle_band.hpp, docs/needle-model.md) against closed-form
// solutions of a rigid shaft of radius a in elastic tissue (shear modulus G, Poisson ratio ν):
// - Antiplane shear: the shaft through the whole length L of a prism of square section s, its four long
//   faces held, its end faces holding x and y only (the 3D field is then exactly the antiplane one),
//   moved along its axis by U, carries F = L·2πGU/ln(ρ/a), ρ = 4√π s/Γ(1/4)² = 0.5394 s the inner
//   conformal radius of the square at its centre (Schwarz–Christoffel; exact up to O((a/s)⁴)).
// - Lateral, plane strain: the shaft moved across its axis by U inside a held coaxial cylinder of
//   radius b carries per length F/L = 8πG(1−ν)(3−4ν)U / [(3−4ν)² ln(b/a) − (b²−a²)/(b²+a²)]
//   (Baguelin, Frank & Saïd 1977, Géotechnique 27(3):405–434, the laterally loaded pile's reaction;
//   Randolph 1981, Géotechnique 31(2):247–259, uses its ln term; derived from Muskhelishvili's
//   potentials in docs/needle-model.md).
// The old coupling — a line of stations on the axis — fails both (its force depends on the mesh, not
// on a): the measurement is in docs/needle-model.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>
#include <vim/fem/elasticity.hpp>
#include <vim/needle/needle_band.hpp>

#include "../../fem/box_mesh.hpp"

namespace {

using V3 = Eigen::Vector3d;
using vim::fem::DirichletBC;
using vim::fem::ElasticModel;
using vim::fem::PointConstraint;
using vim::fem::Region;
using vim::needle::NeedleBand;

constexpr double kPi = 3.14159265358979323846;
constexpr double kE = 30.0, kNu = 0.3, kU = 0.1;  // kPa, -, mm: forces in mN
constexpr double kSide = 20.0;                    // prism section s (mm)
constexpr double kOuter = 10.0;                   // held cylinder radius b (mm)
// The fields are uniform along the shaft: a slice of a few layers (L = kLayers·h, stations 2h long)
// holds the whole answer and keeps the P2 meshes small.
constexpr int kLayers = 4;

double shear_modulus() { return kE / (2.0 * (1.0 + kNu)); }

double antiplane_theory_per_length(double a) {
  const double rho = 4.0 * std::sqrt(kPi) * kSide / std::pow(std::tgamma(0.25), 2);
  return 2.0 * kPi * shear_modulus() * kU / std::log(rho / a);
}

double lateral_theory_per_length(double a) {
  const double k = 3.0 - 4.0 * kNu, b2 = kOuter * kOuter, a2 = a * a;
  return 8.0 * kPi * shear_modulus() * (1.0 - kNu) * k * kU /
         (k * k * std::log(kOuter / a) - (b2 - a2) / (b2 + a2));
}

// Node coordinates on [−half, half]: spacing h up to `core` from 0, then growing by 1.3 per cell.
std::vector<double> graded_axis(double half, double h, double core) {
  std::vector<double> pos{0.0};
  double step = h;
  while (pos.back() < half - 1e-9) {
    if (pos.back() >= core - 1e-9) step *= 1.3;
    double next = pos.back() + step;
    if (next > half - 0.4 * step) next = half;
    pos.push_back(next);
  }
  std::vector<double> axis;
  for (std::size_t i = pos.size(); i-- > 1;) axis.push_back(-pos[i]);
  axis.insert(axis.end(), pos.begin(), pos.end());
  return axis;
}

// How the shaft is coupled: the band rows (needle_band_for with factor c when c > 0, else the default
// band) or the old line of axis points.
struct Coupling {
  bool line = false;
  double c = 0.0;
  bool ring = false;     // with c: one ring of radius max(a, c·h) instead of the shell
  double station = 2.0;  // station length over h
};

// The stations tiling [0, L] along the z axis, every one moved by `u` (model axes).
std::vector<PointConstraint<3>> shaft_stations(double a, double h, unsigned degree, double L, const V3& u,
                                               const Coupling& how) {
  const int n = std::max(1, static_cast<int>(std::lround(L / (how.station * h))));
  const double ell = L / n;
  const V3 axis(0.0, 0.0, 1.0);
  NeedleBand band = how.c > 0.0 ? vim::needle::needle_band_for(a, h, ell, how.c)
                                : vim::needle::default_needle_band(a, h, ell, degree);
  if (how.ring) band.coupling_radius = std::max(a, how.c * h), band.inner_fraction = 1.0, band.n_radial = 1;
  std::vector<PointConstraint<3>> pts;
  for (int k = 0; k < n; ++k) {
    const V3 centre(0.0, 0.0, (k + 0.5) * ell);
    if (how.line) {
      pts.push_back({centre, u});
      continue;
    }
    const Eigen::Matrix3d frame = vim::needle::needle_frame(axis);
    pts.push_back(vim::needle::needle_band_constraint(centre, axis, band, frame.transpose() * u, kE, kNu));
  }
  return pts;
}

vim::fem::SolverOptions direct() {
  vim::fem::SolverOptions o;
  o.type = vim::fem::SolverOptions::Type::direct;
  return o;
}

V3 total_force(const vim::fem::Solution<3>& s) {
  V3 f = V3::Zero();
  for (const auto& p : s.point_force) f += p;
  return f;
}

// The share of the shaft's displacement U taken by the annulus in series: the mean over the stations of
// κ_c F_c / U along the row c of the stations' axes that the shaft moves along.
double compliance_share(const std::vector<PointConstraint<3>>& pts, const vim::fem::Solution<3>& s, int row) {
  double sum = 0.0;
  for (std::size_t j = 0; j < pts.size(); ++j)
    sum += pts[j].compliance[row] * pts[j].axes.col(row).dot(s.point_force[j]) / kU;
  return pts.empty() ? 0.0 : sum / static_cast<double>(pts.size());
}

// Antiplane case: force per length along the axis over its theory (1 = exact); `share`: the annulus
// compliance's share of U (compliance_share).
double antiplane_ratio(double a, double h, unsigned degree, const Coupling& how, double* share = nullptr) {
  const double L = kLayers * h;
  const auto xy = graded_axis(0.5 * kSide, h, std::max(2.0 * h, 2.0 * a));
  const auto mesh = vim::test::kuhn_mesh<3>({{xy, xy, vim::test::linspace(0.0, L, kLayers)}});
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), kE), kNu, degree);
  const double tol = 1e-6;
  model.add_dirichlet(DirichletBC<3>{Region<3>{"long faces", [&](const V3& x) {
                                                 return std::abs(x[0]) > 0.5 * kSide - tol ||
                                                        std::abs(x[1]) > 0.5 * kSide - tol;
                                               }}});
  DirichletBC<3> ends{Region<3>{"end faces", [&](const V3& x) { return x[2] < tol || x[2] > L - tol; }}};
  ends.components = {{true, true, false}};
  model.add_dirichlet(ends);
  const auto pts = shaft_stations(a, h, degree, L, V3(0, 0, kU), how);
  const auto s = model.solve(pts, direct());
  if (share) *share = compliance_share(pts, s, 2);
  return total_force(s)[2] / L / antiplane_theory_per_length(a);
}

// A disk mesh of radius kOuter, L thick: the graded square grid, its outer part blended onto the circle.
vim::SimplexMesh<3> disk_mesh(double h, double core, double L) {
  const auto xy = graded_axis(kOuter, h, core);
  auto mesh = vim::test::kuhn_mesh<3>({{xy, xy, vim::test::linspace(0.0, L, kLayers)}});
  for (auto& x : mesh.points) {
    const double sq = std::max(std::abs(x[0]), std::abs(x[1])), r = std::hypot(x[0], x[1]);
    if (sq <= core) continue;
    const double t = (sq - core) / (kOuter - core);
    const double scale = (1.0 - t) + t * sq / r;
    x[0] *= scale, x[1] *= scale;
  }
  vim::orient_positively(mesh);
  return mesh;
}

// Lateral case: force per length along x over its theory (1 = exact); `share` as for antiplane_ratio.
double lateral_ratio(double a, double h, unsigned degree, const Coupling& how, double* share = nullptr) {
  const double L = kLayers * h;
  const auto mesh = disk_mesh(h, std::max(2.0 * h, 2.0 * a), L);
  ElasticModel<3> model(mesh, std::vector<double>(mesh.n_cells(), kE), kNu, degree);
  const double tol = 1e-6, rim = kOuter * (1.0 - 0.02);  // P2 mid-nodes of the rim lie on its chords
  model.add_dirichlet(
      DirichletBC<3>{Region<3>{"outer cylinder", [&](const V3& x) { return std::hypot(x[0], x[1]) > rim; }}});
  DirichletBC<3> ends{Region<3>{"end faces", [&](const V3& x) { return x[2] < tol || x[2] > L - tol; }}};
  ends.components = {{false, false, true}};
  model.add_dirichlet(ends);
  const auto pts = shaft_stations(a, h, degree, L, V3(kU, 0, 0), how);
  const auto s = model.solve(pts, direct());
  if (share) *share = compliance_share(pts, s, 0);
  return total_force(s)[0] / L / lateral_theory_per_length(a);
}

}  // namespace

// The default band, a = 0.5 and 1 mm: the force per length within 3% of theory on the finer of two
// meshes, the error not growing with refinement, and the ratio of the two radii's forces within 3% of
// the theory's 1.29 (a line of axis points: 0.3–0.55 of theory on the finer meshes, ratio 1.0).
void check_antiplane(unsigned degree, double coarse_h, double fine_h) {
  std::vector<double> fine(2);
  for (int i = 0; i < 2; ++i) {
    const double a = 0.5 * (i + 1);
    const double coarse = antiplane_ratio(a, coarse_h, degree, {});
    const double r = antiplane_ratio(a, fine_h, degree, {});
    std::printf("antiplane P%u a %.2f: force / theory %.4f (h %.2f), %.4f (h %.2f)\n", degree, a, coarse,
                coarse_h, r, fine_h);
    EXPECT_NEAR(r, 1.0, 0.03) << "P" << degree << " a " << a;
    EXPECT_LE(std::abs(r - 1.0), std::abs(coarse - 1.0) + 1e-3) << "P" << degree << " a " << a;
    fine[i] = r * antiplane_theory_per_length(a);
  }
  const double theory = antiplane_theory_per_length(1.0) / antiplane_theory_per_length(0.5);
  EXPECT_NEAR(fine[1] / fine[0], theory, 0.03 * theory) << "P" << degree;
}

TEST(NeedleCoupling, AntiplaneShaftForceMatchesTheoryP2) { check_antiplane(2, 2.0, 0.5); }
TEST(NeedleCoupling, AntiplaneShaftForceMatchesTheoryP1) { check_antiplane(1, 1.0, 0.25); }

// The default band, a = 0.5 and 1 mm, within 3% of the plane-strain closed form (a line of axis points:
// 0.21–0.47 of theory on these meshes).
TEST(NeedleCoupling, LateralShaftForceMatchesTheory) {
  for (unsigned degree : {2u, 1u}) {
    const double h = degree == 2 ? 1.0 : 0.25;
    for (double a : {0.5, 1.0}) {
      const double r = lateral_ratio(a, h, degree, {});
      std::printf("lateral P%u a %.2f h %.2f: force / theory %.4f\n", degree, a, h, r);
      EXPECT_NEAR(r, 1.0, 0.03) << "P" << degree << " a " << a;
    }
  }
}

// The measurement behind default_needle_band (docs/needle-model.md), not run by CTest:
//   build/tests/test_needle_coupling --gtest_also_run_disabled_tests --gtest_filter='*Study*'
// Force over theory for the old line coupling, one ring of radius max(a, c·h), the shell of
// needle_band_for for several c, and the default band.
void coupling_study(bool lateral) {
  std::printf("case degree a h | line | ring c=1 2 | shell c=1 1.5 2 2.5 3 | default\n");
  for (unsigned degree : {1u, 2u})
    for (double a : {0.5, 1.0})
      for (double h : {2.0, 1.0, 0.5, 0.25}) {
        if (degree == 2 && h < 0.5) continue;
        const auto ratio = [&](const Coupling& how) {
          return lateral ? lateral_ratio(a, h, degree, how) : antiplane_ratio(a, h, degree, how);
        };
        std::printf("%s P%u %.2f %.2f | %.4f |", lateral ? "lateral" : "antiplane", degree, a, h,
                    ratio({true}));
        for (double c : {1.0, 2.0}) std::printf(" %.4f", ratio({false, c, true}));
        std::printf(" |");
        for (double c : {1.0, 1.5, 2.0, 2.5, 3.0}) std::printf(" %.4f", ratio({false, c}));
        std::printf(" | %.4f\n", ratio({}));
        std::fflush(stdout);
      }
}

TEST(NeedleCoupling, DISABLED_AntiplaneStudy) { coupling_study(false); }
TEST(NeedleCoupling, DISABLED_LateralStudy) { coupling_study(true); }

// The default band with stations of other lengths ℓ (the shafts' fields are uniform along the axis, so
// the force per length must not depend on ℓ), not run by CTest:
//   build/tests/test_needle_coupling --gtest_also_run_disabled_tests --gtest_filter='*StationLength*'
TEST(NeedleCoupling, DISABLED_StationLengthStudy) {
  std::printf("case degree a h | station length / h = 0.5 1 2 4\n");
  for (bool lateral : {false, true})
    for (unsigned degree : {1u, 2u}) {
      const double a = 0.5, h = 1.0;
      std::printf("%s P%u %.2f %.2f |", lateral ? "lateral" : "antiplane", degree, a, h);
      for (double station : {0.5, 1.0, 2.0, 4.0}) {
        Coupling how;
        how.station = station;
        std::printf(" %.4f", lateral ? lateral_ratio(a, h, degree, how) : antiplane_ratio(a, h, degree, how));
        std::fflush(stdout);
      }
      std::printf("\n");
    }
}

// Coarse meshes (h ≫ a): the default band is then a solid cylinder of radius c·h (R_e = 0.78 c·h ≫ a), and
// the annulus compliance in series carries most of the shaft's displacement U (its share κ F / U > 0.6;
// at the finest meshes above R_e = a and κ = 0). The force then checks κ_z and κ_x themselves: within 3%
// of theory, where κ scaled by 1.1 moves it by 1/(1 + 0.1·share), 6–9%
// (tests/sabotage/axial-compliance-scaled.patch, tests/sabotage/lateral-compliance-scaled.patch).
struct CoarseCase {
  unsigned degree;
  double a, h;
};

void check_coarse(bool lateral, const std::vector<CoarseCase>& cases) {
  for (const CoarseCase& c : cases) {
    double share = 0.0;
    const double r = lateral ? lateral_ratio(c.a, c.h, c.degree, {}, &share)
                             : antiplane_ratio(c.a, c.h, c.degree, {}, &share);
    std::printf("%s P%u a %.2f h %.2f: force / theory %.4f, compliance share %.3f\n",
                lateral ? "lateral" : "antiplane", c.degree, c.a, c.h, r, share);
    EXPECT_GT(share, 0.55) << "P" << c.degree << " a " << c.a;
    EXPECT_NEAR(r, 1.0, 0.03) << "P" << c.degree << " a " << c.a;
  }
}

TEST(NeedleCoupling, AxialComplianceOnACoarseMeshMatchesTheory) {
  check_coarse(false, {{2, 0.1, 3.0}, {2, 0.25, 3.0}, {1, 0.25, 2.0}});
}

// P1 at h = 1 mm: on coarser P1 meshes R = 3h reaches the held cylinder (b = 10 mm).
TEST(NeedleCoupling, LateralComplianceOnACoarseMeshMatchesTheory) {
  check_coarse(true, {{2, 0.1, 3.0}, {2, 0.25, 3.0}, {1, 0.25, 1.0}});
}

// Coarse meshes (h ≫ a) and the share of the annulus compliance in the answer, not run by CTest:
//   build/tests/test_needle_coupling --gtest_also_run_disabled_tests --gtest_filter='*CoarseStudy*'
TEST(NeedleCoupling, DISABLED_CoarseStudy) {
  std::printf("case degree a h | force / theory, compliance share\n");
  for (bool lateral : {false, true})
    for (unsigned degree : {2u, 1u})
      for (double a : {0.1, 0.25, 0.5})
        for (double h : {1.0, 2.0, 3.0}) {
          double share = 0.0;
          const double r =
              lateral ? lateral_ratio(a, h, degree, {}, &share) : antiplane_ratio(a, h, degree, {}, &share);
          std::printf("%s P%u %.2f %.2f | %.4f %.3f\n", lateral ? "lateral" : "antiplane", degree, a, h, r,
                      share);
          std::fflush(stdout);
        }
}

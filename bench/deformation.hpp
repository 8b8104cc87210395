// Deformation validation (docs/architecture.md, "The voxel reference"): uniaxial compression of an
// image phantom solved on a coarse simplex model (VIM or regular grid, element modulus = element
// mean, Eq. 15) and on the fine voxel reference (one Q1 cell per voxel, E = voxel value), with
// identical boundary conditions; relative L2 / max displacement error over sample points inside
// both domains, and the strain-energy error.
#pragma once

#include <vim/fem/elasticity.hpp>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>
#include <vim/voxel_statistics.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace vim::validation {

template <int dim>
using Vec = fem::Vec<dim>;

// Loading: the face x_{dim-1} = min is clamped (u = 0), the face x_{dim-1} = max is pushed down by
// `strain` × height along axis dim-1, its other components free.
template <int dim>
void add_compression(fem::ElasticModel<dim>& model, const Vec<dim>& lo, const Vec<dim>& hi, double strain) {
  const int axis = dim - 1;
  const double tol = 1e-6 * (hi - lo).norm();
  fem::DirichletBC<dim> bottom{fem::box_face_region<dim>(lo, hi, axis, false, tol)};
  model.add_dirichlet(bottom);
  fem::DirichletBC<dim> top{fem::box_face_region<dim>(lo, hi, axis, true, tol)};
  top.components = fem::DirichletBC<dim>::filled(false);
  top.components[axis] = true;
  top.value = Vec<dim>::Zero();
  top.value[axis] = -strain * (hi[axis] - lo[axis]);
  model.add_dirichlet(top);
}

// Eq. 15: E_j = mean of the voxel values whose centres lie in cell j (the mesher's enclosure).
template <int dim>
std::vector<double> element_moduli(const Image<dim>& image, const SimplexMesh<dim>& mesh) {
  const VoxelStatistics<dim> stats(image);
  std::vector<double> e(mesh.n_cells());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) e[c] = stats.value(cell_points(mesh, c)).mean;
  return e;
}

template <int dim>
struct Reference {
  std::vector<Vec<dim>> points;  // sample points (voxel centres, every `stride`-th per axis)
  std::vector<Vec<dim>> u;       // reference displacement there
  double strain_energy = 0.0;
  unsigned n_dofs = 0;
};

template <int dim>
Reference<dim> solve_reference(const Image<dim>& image, double nu, double strain, long stride = 1) {
  std::vector<double> e(image.data.begin(), image.data.end());
  auto model = fem::ElasticModel<dim>::voxel_grid(image.size, image.box_min(), image.box_max(), std::move(e), nu);
  add_compression<dim>(model, image.box_min(), image.box_max(), strain);
  const auto solution = model.solve();
  Reference<dim> ref;
  ref.strain_energy = solution.strain_energy;
  ref.n_dofs = model.n_dofs();
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const auto i = image.index_of(k);
    bool keep = true;
    for (int a = 0; a < dim; ++a) keep = keep && i[a] % stride == stride / 2;
    if (keep) ref.points.push_back(image.point_of(i));
  }
  fem::PointSample info;
  ref.u = model.sample(ref.points, &info);
  std::vector<Vec<dim>> p, u;  // keep the points inside the reference domain
  for (std::size_t k = 0; k < ref.points.size(); ++k)
    if (info.inside.empty() || info.inside[k]) p.push_back(ref.points[k]), u.push_back(ref.u[k]);
  ref.points = std::move(p);
  ref.u = std::move(u);
  return ref;
}

struct Error {
  double relative_l2 = 0.0;   // sqrt(Σ|u − u_ref|² / Σ|u_ref|²)
  double max = 0.0;           // max |u − u_ref|
  double max_reference = 0.0; // max |u_ref| (scale for `max`)
  double energy_relative = 0.0;  // |W − W_ref| / W_ref
  std::size_t points = 0;
  unsigned n_dofs = 0;
};

// Solves the coarse simplex model with the same loading and compares it at the reference points.
template <int dim>
Error coarse_error(const Image<dim>& image, const SimplexMesh<dim>& mesh, std::vector<double> moduli, double nu,
                   double strain, const Reference<dim>& ref) {
  fem::ElasticModel<dim> model(mesh, std::move(moduli), nu, 1);
  add_compression<dim>(model, image.box_min(), image.box_max(), strain);
  const auto solution = model.solve();
  fem::PointSample info;
  const auto u = model.sample(ref.points, &info);
  Error err;
  double num = 0.0, den = 0.0;
  for (std::size_t k = 0; k < ref.points.size(); ++k) {
    if (!info.inside.empty() && !info.inside[k]) continue;
    const double d = (u[k] - ref.u[k]).norm();
    num += d * d;
    den += ref.u[k].squaredNorm();
    err.max = std::max(err.max, d);
    err.max_reference = std::max(err.max_reference, ref.u[k].norm());
    ++err.points;
  }
  err.relative_l2 = den > 0.0 ? std::sqrt(num / den) : 0.0;
  err.energy_relative = std::abs(solution.strain_energy - ref.strain_energy) / ref.strain_energy;
  err.n_dofs = model.n_dofs();
  return err;
}

}  // namespace vim::validation

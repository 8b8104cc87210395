// Post-processing and sampling of the elastic model (docs/architecture.md, fem module): vertex
// displacements, strain and stress at cell centroids, von Mises stress, strain energy and Dirichlet
// reactions of a solution; point location (CellLocator) and the displacement at arbitrary points and
// at edge midpoints; the strain energy of a given vertex field.
#include <deal.II/base/quadrature.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vim/fem/material.hpp>

#include "linear_elastic_material.hpp"
#include "model_state.hpp"

namespace vim::fem {

using namespace dealii;

// Per cell, its DoFs and the gradients of the scalar basis functions at the centroid (when they fit in
// ~400 MB); per vertex, its DoFs.
template <int dim>
void ElasticModel<dim>::Impl::build_post_cache() {
  const unsigned dpc = fe->n_dofs_per_cell();
  const unsigned ns = fe->base_element(0).n_dofs_per_cell();
  const std::size_t nc = tria.n_active_cells();
  vertex_dofs.assign(tria.n_vertices(), {});
  const double bytes = double(nc) * (dpc * sizeof(types::global_dof_index) + ns * dim * sizeof(double));
  post_cache = bytes < 400e6;
  if (post_cache) {
    cell_dofs.resize(nc * dpc);
    centroid_grads.resize(nc * ns * dim);
    cell_index.resize(nc);
  }
  Quadrature<dim> cq(std::vector<Point<dim>>{unit_centroid});
  FEValues<dim> cv(*mapping, *fe, cq, update_gradients);
  std::size_t k = 0;
  for (const auto& cell : dof.active_cell_iterators()) {
    for (const unsigned v : cell->vertex_indices())
      for (unsigned c = 0; c < unsigned(dim); ++c)
        vertex_dofs[cell->vertex_index(v)][c] = cell->vertex_dof_index(v, c);
    if (post_cache) {
      cv.reinit(cell);
      std::vector<types::global_dof_index> idx(dpc);
      cell->get_dof_indices(idx);
      std::copy(idx.begin(), idx.end(), cell_dofs.begin() + k * dpc);
      // the scalar basis gradient: take the component-0 copy of each scalar function
      for (unsigned i = 0; i < dpc; ++i) {
        const auto [c, sidx] = fe->system_to_component_index(i);
        if (c != 0) continue;
        const Tensor<1, dim> g = cv.shape_grad(i, 0);
        for (int d = 0; d < dim; ++d) centroid_grads[(k * ns + sidx) * dim + d] = g[d];
      }
      cell_index[k] = cell->material_id();
    }
    ++k;
  }
}

namespace {

// Centroid strain, stress and von Mises stress of every cell from u: through the post-processing cache
// when it was built, else cell by cell with FEValues.
template <int dim, class State>
void cell_fields(const State& m, const Vector<double>& u, Solution<dim>& s) {
  const unsigned dpc = m.fe->n_dofs_per_cell();
  const unsigned ns = m.fe->base_element(0).n_dofs_per_cell();
  const unsigned nc = m.tria.n_active_cells();
  if (m.post_cache) {
    std::vector<unsigned> comp(dpc), scalar(dpc);
    for (unsigned i = 0; i < dpc; ++i)
      comp[i] = m.fe->system_to_component_index(i).first,
      scalar[i] = m.fe->system_to_component_index(i).second;
    for (std::size_t k = 0; k < nc; ++k) {
      const types::global_dof_index* idx = &m.cell_dofs[k * dpc];
      const double* G = &m.centroid_grads[k * ns * dim];
      Eigen::Matrix<double, dim, dim> grad = Eigen::Matrix<double, dim, dim>::Zero();
      for (unsigned i = 0; i < dpc; ++i) {
        const double ui = u[idx[i]];
        for (int d = 0; d < dim; ++d) grad(comp[i], d) += ui * G[scalar[i] * dim + d];
      }
      const unsigned j = m.cell_index[k];
      s.cell_strain[j] = 0.5 * (grad + grad.transpose());
      m.stress_of(s.cell_strain[j], m.E[j], s.cell_stress[j], s.von_mises[j]);
    }
    return;
  }
  Quadrature<dim> cq(std::vector<Point<dim>>{m.unit_centroid});
  FEValues<dim> cv(*m.mapping, *m.fe, cq, update_gradients);
  std::vector<types::global_dof_index> idx(dpc);
  std::vector<double> ue(dpc);
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < dpc; ++i) ue[i] = u[idx[i]];
    const unsigned j = cell->material_id();
    s.cell_strain[j] = m.centroid_strain(cell, cv, ue);
    m.stress_of(s.cell_strain[j], m.E[j], s.cell_stress[j], s.von_mises[j]);
  }
}

}  // namespace

template <int dim>
Solution<dim> ElasticModel<dim>::Impl::postprocess() {
  Solution<dim> s;
  if (distributed) {
    s = distributed->fields(u);
  } else {
    postprocess_serial(s);
  }
  s.stats.n_dofs = n_solve_dofs();
  s.stats.assemble_seconds = assemble_seconds;
  return s;
}

template <int dim>
void ElasticModel<dim>::Impl::postprocess_serial(Solution<dim>& s) {
  if (vertex_dofs.empty()) build_post_cache();
  s.vertex_displacement.resize(tria.n_vertices());
  for (std::size_t v = 0; v < vertex_dofs.size(); ++v)
    for (int c = 0; c < dim; ++c) s.vertex_displacement[v][c] = u[vertex_dofs[v][c]];
  const unsigned nc = tria.n_active_cells();
  s.cell_strain.assign(nc, Eigen::Matrix<double, dim, dim>::Zero());
  s.cell_stress.assign(nc, Eigen::Matrix<double, dim, dim>::Zero());
  s.von_mises.assign(nc, 0.0);
  cell_fields<dim>(*this, u, s);
  Vector<double> Ku(u.size());
  K_full.vmult(Ku, u);
  s.strain_energy = 0.5 * (u * Ku);
  s.dirichlet_reaction.assign(bcs.size(), Vec<dim>::Zero());
  for (unsigned i = 0; i < u.size(); ++i)
    if (dof_bc[i] >= 0) s.dirichlet_reaction[dof_bc[i]][dof_component[i]] += Ku[i] - f_full[i];
}

template <int dim>
Eigen::Matrix<double, dim, dim> ElasticModel<dim>::Impl::centroid_strain(
    const Cell& cell, FEValues<dim>& cv, const std::vector<double>& ue) const {
  Eigen::Matrix<double, dim, dim> grad = Eigen::Matrix<double, dim, dim>::Zero();
  if (!voxel && degree == 1) {
    std::array<Tensor<1, dim>, dim + 1> g;
    barycentric_gradients<dim>(cell, g);
    for (unsigned i = 0; i < ue.size(); ++i) {
      const auto [c, v] = fe->system_to_component_index(i);
      for (int d = 0; d < dim; ++d) grad(c, d) += ue[i] * g[v][d];
    }
    return 0.5 * (grad + grad.transpose());
  }
  cv.reinit(cell);
  for (unsigned i = 0; i < ue.size(); ++i) {
    const unsigned c = fe->system_to_component_index(i).first;
    const Tensor<1, dim> g = cv.shape_grad(i, 0);
    for (int d = 0; d < dim; ++d) grad(c, d) += ue[i] * g[d];
  }
  return 0.5 * (grad + grad.transpose());
}

double shear_modulus(double youngs_modulus, double poisson_ratio) {
  return LinearElasticMaterial<3>::shear_modulus(youngs_modulus, poisson_ratio);
}

std::pair<double, double> lame_parameters(double youngs_modulus, double poisson_ratio) {
  const Lame<> c = LinearElasticMaterial<3>::lame(youngs_modulus, poisson_ratio);
  return {c.lambda, c.mu};
}

template <int dim>
LinearElasticMaterial<dim> ElasticModel<dim>::Impl::material() const {
  return LinearElasticMaterial<dim>(E, nu);
}

template <int dim>
void ElasticModel<dim>::Impl::stress_of(const Eigen::Matrix<double, dim, dim>& eps, double E_cell,
                                        Eigen::Matrix<double, dim, dim>& sigma, double& von_mises) const {
  const Lame<> law = material().of_modulus(E_cell);
  sigma = Law::stress(law, eps);
  // full 3×3 stress; in 2D (plane strain) σ_zz from the material
  Eigen::Matrix3d s3 = Eigen::Matrix3d::Zero();
  s3.topLeftCorner<dim, dim>() = sigma;
  if (dim == 2) s3(2, 2) = Law::out_of_plane_stress(law, eps);
  const Eigen::Matrix3d dev = s3 - s3.trace() / 3.0 * Eigen::Matrix3d::Identity();
  von_mises = std::sqrt(1.5 * (dev.array() * dev.array()).sum());
}

// ================================================================================================
// point location

template <int dim>
const CellLocator<dim>& ElasticModel<dim>::locator() const {
  return impl_->cell_locator();
}

template <int dim>
const CellLocator<dim>& ElasticModel<dim>::Impl::cell_locator() const {
  if (locator) return *locator;
  if (voxel) {
    locator = std::make_unique<CellLocator<dim>>(
        CellLocator<dim>::grid(grid_cells, to_vec<dim>(grid_min), to_vec<dim>(grid_max), vertices));
  } else {
    SimplexMesh<dim> mesh;
    mesh.points = vertices;
    mesh.cells = simplices;
    locator = std::make_unique<CellLocator<dim>>(CellLocator<dim>::simplex(mesh));
  }
  return *locator;
}

template <int dim>
void ElasticModel<dim>::Impl::serial_cells() const {
  if (!cell_of_index.empty()) return;
  cell_of_index.assign(E.size(), tria.end());
  for (const auto& cell : tria.active_cell_iterators()) cell_of_index[cell->material_id()] = cell;
}

// The locator's cell (input cell index = material id; voxel index on the grid), accepted when x's
// reference coordinates in it lie in the reference cell within 1e-10 and map back to x.
template <int dim>
typename ElasticModel<dim>::Impl::Located ElasticModel<dim>::Impl::locate(const Point<dim>& x) const {
  const long c = cell_locator().locate(to_vec<dim>(x));
  if (c < 0) return {tria.end(), Point<dim>()};
  serial_cells();
  const auto& cell = cell_of_index[static_cast<std::size_t>(c)];
  if (const auto xi = reference_point<dim>(*mapping, cell, x)) return {cell, *xi};
  return {tria.end(), Point<dim>()};
}

template <int dim>
std::vector<PointStencil> ElasticModel<dim>::Impl::stencils(const std::vector<Vec<dim>>& points) const {
  std::vector<std::pair<long, Point<dim>>> at(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    at[i] = {cell_locator().locate(points[i]), to_point<dim>(points[i])};
  return stencils_in(at);
}

template <int dim>
std::vector<PointStencil> ElasticModel<dim>::Impl::stencils_in(
    const std::vector<std::pair<long, Point<dim>>>& at) const {
  if (distributed) return distributed->stencils(at);
  serial_cells();
  std::vector<PointStencil> out(at.size());
  const auto bc_of = [this](types::global_dof_index d) { return dof_bc.empty() ? -1 : dof_bc[d]; };
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (at[i].first < 0) continue;
    const auto& cell = cell_of_index[static_cast<std::size_t>(at[i].first)];
    const auto xi = reference_point<dim>(*mapping, cell, at[i].second);
    if (!xi) continue;
    out[i] = cell_stencil<dim>(*fe, Cell(&tria, cell->level(), cell->index(), &dof), *xi, constraints, bc_of);
  }
  return out;
}

template <int dim>
std::vector<std::optional<Vec<dim>>> ElasticModel<dim>::Impl::values_in(
    const std::vector<std::pair<long, Point<dim>>>& at) const {
  if (distributed) return distributed->values(at, u);
  serial_cells();
  std::vector<std::optional<Vec<dim>>> out(at.size());
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (at[i].first < 0) continue;
    const auto& cell = cell_of_index[static_cast<std::size_t>(at[i].first)];
    if (const auto xi = reference_point<dim>(*mapping, cell, at[i].second))
      out[i] = cell_value<dim>(*fe, Cell(&tria, cell->level(), cell->index(), &dof), *xi, u);
  }
  return out;
}

template <int dim>
types::global_dof_index ElasticModel<dim>::Impl::n_solve_dofs() const {
  return distributed ? distributed->n_dofs() : dof.n_dofs();
}

template <int dim>
void ElasticModel<dim>::Impl::distribute_constraints(Vector<double>& x) const {
  if (distributed)
    distributed->distribute_constraints(x);
  else
    constraints.distribute(x);
}

// ================================================================================================
// sampling and energies

namespace {

// Multilinear interpolation of vertex values U on the voxel grid of m at x (the Q1 field); false
// outside the grid's box.
template <int dim>
bool grid_interpolate(const ModelAccess::State<dim>& m, const std::vector<Vec<dim>>& U, const Vec<dim>& x,
                      Vec<dim>& v) {
  std::array<long, dim> i0{};
  std::array<double, dim> t{};
  for (int d = 0; d < dim; ++d) {
    const double h = (m.grid_max[d] - m.grid_min[d]) / m.grid_cells[d];
    const double s = (x[d] - m.grid_min[d]) / h;
    if (!(s >= -1e-10 && s <= m.grid_cells[d] + 1e-10)) return false;
    i0[d] = std::min(std::max(static_cast<long>(std::floor(s)), 0L), m.grid_cells[d] - 1);
    t[d] = s - static_cast<double>(i0[d]);
  }
  v = Vec<dim>::Zero();
  for (unsigned corner = 0; corner < (1u << dim); ++corner) {
    double w = 1.0;
    std::size_t index = 0, stride = 1;
    for (int d = 0; d < dim; ++d) {
      const bool up = (corner >> d) & 1u;
      w *= up ? t[d] : 1.0 - t[d];
      index += static_cast<std::size_t>(i0[d] + (up ? 1 : 0)) * stride;
      stride *= static_cast<std::size_t>(m.grid_cells[d] + 1);
    }
    v += w * U[index];
  }
  return true;
}

}  // namespace

template <int dim>
std::vector<Vec<dim>> ElasticModel<dim>::sample(const std::vector<Vec<dim>>& points,
                                                PointSample* info) const {
  const Impl& m = *impl_;
  if (!m.have_solution && !m.grid_vertex_u.empty()) {
    std::vector<Vec<dim>> out(points.size(), Vec<dim>::Zero());
    std::vector<bool> inside(points.size(), false);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!points[i].allFinite())
        throw std::invalid_argument("sample: point " + std::to_string(i) + " is not finite");
      inside[i] = grid_interpolate<dim>(m, m.grid_vertex_u, points[i], out[i]);
    }
    if (info) {
      info->inside = inside;
      info->n_outside = static_cast<std::size_t>(std::count(inside.begin(), inside.end(), false));
    }
    return out;
  }
  if (!m.have_solution)
    throw std::runtime_error("sample: no solution yet; call solve() first");  // solve() built the mesh
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw std::invalid_argument("sample: point " + std::to_string(i) + " is not finite");
  std::vector<Vec<dim>> out(points.size(), Vec<dim>::Zero());
  std::vector<bool> inside(points.size(), false);
  std::vector<std::pair<long, Point<dim>>> at(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    at[i] = {m.cell_locator().locate(points[i]), to_point<dim>(points[i])};
  const std::vector<std::optional<Vec<dim>>> values = m.values_in(at);
  for (std::size_t i = 0; i < points.size(); ++i)
    if ((inside[i] = values[i].has_value())) out[i] = *values[i];
  if (info) {
    info->inside = inside;
    info->n_outside = static_cast<std::size_t>(std::count(inside.begin(), inside.end(), false));
  }
  return out;
}

// The last solution at edge midpoints through the shape functions of a cell holding the edge (no point
// location: the cell is looked up among the input cells).
template <int dim>
std::vector<Vec<dim>> ElasticModel<dim>::edge_midpoint_displacement(
    const std::vector<std::array<int, 2>>& edges) const {
  const Impl& m = *impl_;
  if (m.voxel) throw std::invalid_argument("edge_midpoint_displacement: simplex models only");
  if (!m.have_solution)
    throw std::runtime_error("edge_midpoint_displacement: no solution yet; call solve() first");
  // a cell holding each edge (−1: none), then each edge's midpoint in it
  const auto key = [](const std::array<int, 2>& e) {
    return std::make_pair(std::min(e[0], e[1]), std::max(e[0], e[1]));
  };
  std::map<std::pair<int, int>, long> cell_of_edge;
  for (const auto& e : edges) cell_of_edge[key(e)] = -1;
  for (std::size_t c = 0; c < m.simplices.size(); ++c)
    for (int a = 0; a <= dim; ++a)
      for (int b = a + 1; b <= dim; ++b) {
        const auto it = cell_of_edge.find(key({{m.simplices[c][a], m.simplices[c][b]}}));
        if (it != cell_of_edge.end() && it->second < 0) it->second = static_cast<long>(c);
      }
  std::vector<std::pair<long, Point<dim>>> at(edges.size(), {-1, Point<dim>()});
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const long c = cell_of_edge.at(key(edges[e]));
    if (c >= 0)
      at[e] = {c, to_point<dim>(0.5 * (m.vertices[static_cast<std::size_t>(edges[e][0])] +
                                       m.vertices[static_cast<std::size_t>(edges[e][1])]))};
  }
  std::vector<Vec<dim>> out(edges.size(), Vec<dim>::Zero());
  const std::vector<std::optional<Vec<dim>>> values = m.values_in(at);
  for (std::size_t e = 0; e < edges.size(); ++e)
    if (values[e])
      out[e] = *values[e];
    else
      throw std::invalid_argument("edge_midpoint_displacement: vertices " + std::to_string(edges[e][0]) +
                                  " and " + std::to_string(edges[e][1]) + " are not an edge of the mesh");
  return out;
}

// Element by element (independent of the Dirichlet conditions): Σ ½ u_eᵀ K_e u_e, u interpolated from
// the vertex values with the linear element.
template <int dim>
double ElasticModel<dim>::strain_energy_of(const std::vector<Vec<dim>>& U) const {
  Impl& m = *impl_;
  m.ensure_mesh();
  if (U.size() != m.tria.n_vertices()) {
    std::ostringstream s;
    s << "strain_energy_of: " << U.size() << " vertex values for " << m.tria.n_vertices() << " vertices";
    throw std::invalid_argument(s.str());
  }
  const unsigned n = m.dof.n_dofs();
  Vector<double> u(n);
  const auto& unit = m.fe->get_unit_support_points();
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < idx.size(); ++i) {
      const unsigned c = m.fe->system_to_component_index(i).first;
      double v = 0.0;
      for (const unsigned k : cell->vertex_indices())
        v += m.linear_fe->shape_value(k, unit[i]) * U[cell->vertex_index(k)][c];
      u[idx[i]] = v;
    }
  }
  auto fv = m.make_fe_values();
  auto ffv = m.make_face_values();
  const unsigned dpc = m.fe->n_dofs_per_cell();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc), ue(dpc), Ku(dpc);
  double energy = 0.0;
  for (const auto& cell : m.dof.active_cell_iterators()) {
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < dpc; ++i) ue[i] = u[idx[i]];
    Ke.vmult(Ku, ue);
    energy += 0.5 * (ue * Ku);
  }
  return energy;
}

#define VIM_FEM_POSTPROCESS(dim)                                                                            \
  template void ElasticModel<dim>::Impl::build_post_cache();                                                \
  template Solution<dim> ElasticModel<dim>::Impl::postprocess();                                            \
  template void ElasticModel<dim>::Impl::postprocess_serial(Solution<dim>&);                                \
  template Eigen::Matrix<double, dim, dim> ElasticModel<dim>::Impl::centroid_strain(                        \
      const Cell&, FEValues<dim>&, const std::vector<double>&) const;                                       \
  template LinearElasticMaterial<dim> ElasticModel<dim>::Impl::material() const;                            \
  template void ElasticModel<dim>::Impl::stress_of(const Eigen::Matrix<double, dim, dim>&, double,          \
                                                   Eigen::Matrix<double, dim, dim>&, double&) const;        \
  template std::vector<Vec<dim>> ElasticModel<dim>::sample(const std::vector<Vec<dim>>&, PointSample*)      \
      const;                                                                                                \
  template std::vector<Vec<dim>> ElasticModel<dim>::edge_midpoint_displacement(                             \
      const std::vector<std::array<int, 2>>&) const;                                                        \
  template double ElasticModel<dim>::strain_energy_of(const std::vector<Vec<dim>>&) const;                  \
  template const CellLocator<dim>& ElasticModel<dim>::locator() const;                                      \
  template const CellLocator<dim>& ElasticModel<dim>::Impl::cell_locator() const;                           \
  template ElasticModel<dim>::Impl::Located ElasticModel<dim>::Impl::locate(const Point<dim>&) const;       \
  template std::vector<PointStencil> ElasticModel<dim>::Impl::stencils(const std::vector<Vec<dim>>&) const; \
  template std::vector<PointStencil> ElasticModel<dim>::Impl::stencils_in(                                  \
      const std::vector<std::pair<long, Point<dim>>>&) const;                                               \
  template types::global_dof_index ElasticModel<dim>::Impl::n_solve_dofs() const;                           \
  template void ElasticModel<dim>::Impl::distribute_constraints(Vector<double>&) const;
VIM_FEM_POSTPROCESS(2)
VIM_FEM_POSTPROCESS(3)

}  // namespace vim::fem

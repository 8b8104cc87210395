// Small-strain linear elasticity with deal.II (paper §VI-C; docs/architecture.md, fem module), set-up
// and assembly: the triangulation from a SimplexMesh (P1/P2 simplices) or a voxel grid (Q1
// hexahedra), the conditions (Dirichlet regions along any axes, surface loads, body force, volume
// supports), and the assembly of K and f with per-cell Lamé parameters.
#include <deal.II/base/memory_consumption.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vim/point_text.hpp>

#include "input_checks.hpp"
#include "linear_elastic_material.hpp"
#include "model_state.hpp"

namespace vim::fem {

using namespace dealii;

namespace {

// Grid vertices in lexicographic order (axis 0 fastest), the numbering subdivided_hyper_rectangle
// uses (ensure_mesh checks it).
template <int dim>
std::vector<Vec<dim>> grid_vertices(const std::array<long, dim>& cells, const Vec<dim>& box_min,
                                    const Vec<dim>& box_max) {
  std::array<long, dim> nv;
  std::size_t n_vertices = 1;
  for (int d = 0; d < dim; ++d) nv[d] = cells[d] + 1, n_vertices *= static_cast<std::size_t>(nv[d]);
  std::vector<Vec<dim>> vertices(n_vertices);
  for (std::size_t v = 0; v < n_vertices; ++v) {
    std::size_t r = v;
    for (int d = 0; d < dim; ++d) {
      const long i = static_cast<long>(r % static_cast<std::size_t>(nv[d]));
      r /= static_cast<std::size_t>(nv[d]);
      vertices[v][d] = box_min[d] + i * ((box_max[d] - box_min[d]) / cells[d]);
    }
  }
  return vertices;
}

// The cells of `mesh` with the vertex order of those of negative measure reversed (deal.II's
// orientation), as the serial and the distributed triangulations take them.
template <int dim>
std::vector<typename SimplexMesh<dim>::Cell> positively_oriented(const SimplexMesh<dim>& mesh) {
  std::vector<Point<dim>> pts(mesh.points.size());
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = to_point<dim>(mesh.points[i]);
  std::vector<CellData<dim>> cells(mesh.cells.size(), CellData<dim>(dim + 1));
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int k = 0; k <= dim; ++k) cells[c].vertices[k] = static_cast<unsigned>(mesh.cells[c][k]);
  GridTools::invert_cells_with_negative_measure(pts, cells);
  std::vector<typename SimplexMesh<dim>::Cell> out(cells.size());
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int k = 0; k <= dim; ++k) out[c][k] = static_cast<int>(cells[c].vertices[k]);
  return out;
}

}  // namespace

// ================================================================================================
// construction

template <int dim>
ElasticModel<dim>::ElasticModel() : impl_(std::make_unique<Impl>()) {}

template <int dim>
ElasticModel<dim>::ElasticModel(const SimplexMesh<dim>& mesh, std::vector<double> youngs_modulus,
                                double poisson_ratio, unsigned degree)
    : impl_(std::make_unique<Impl>()) {
  if (degree != 1 && degree != 2)
    throw std::invalid_argument("ElasticModel: element degree " + std::to_string(degree) +
                                " is not supported; use 1 or 2");
  check_poisson_ratio(poisson_ratio);
  check_moduli(youngs_modulus, mesh.cells.size(), "ElasticModel");
  check_simplex_mesh(mesh);
  if (mesh.cells.size() >= numbers::invalid_material_id)
    throw std::invalid_argument("ElasticModel: too many cells");
  Impl& m = *impl_;
  m.E = std::move(youngs_modulus);
  m.nu = poisson_ratio;
  m.degree = degree;
  m.vertices.assign(mesh.points.begin(), mesh.points.end());
  m.simplices = positively_oriented<dim>(mesh);

  m.fe = std::make_unique<FESystem<dim>>(FE_SimplexP<dim>(degree), dim);
  m.linear_fe = std::make_unique<FE_SimplexP<dim>>(1);
  m.mapping = std::make_unique<MappingFE<dim>>(FE_SimplexP<dim>(1));
  m.quadrature = std::make_unique<QGaussSimplex<dim>>(degree + 1);
  m.face_quadrature = std::make_unique<QGaussSimplex<dim - 1>>(degree + 1);
  for (int d = 0; d < dim; ++d) m.unit_centroid[d] = 1.0 / (dim + 1);
}

template <int dim>
ElasticModel<dim> ElasticModel<dim>::voxel_grid(const std::array<long, dim>& cells, const Vec<dim>& box_min,
                                                const Vec<dim>& box_max, std::vector<double> youngs_modulus,
                                                double poisson_ratio) {
  check_voxel_grid<dim>(cells, box_min, box_max);
  std::size_t n = 1;
  for (int d = 0; d < dim; ++d) n *= static_cast<std::size_t>(cells[d]);
  check_poisson_ratio(poisson_ratio);
  check_moduli(youngs_modulus, n, "voxel_grid");
  if (n >= numbers::invalid_material_id) throw std::invalid_argument("voxel_grid: too many cells");

  ElasticModel model;
  Impl& m = *model.impl_;
  m.voxel = true;
  m.E = std::move(youngs_modulus);
  m.nu = poisson_ratio;
  m.degree = 1;
  m.grid_cells = cells;
  m.grid_min = to_point<dim>(box_min);
  m.grid_max = to_point<dim>(box_max);
  m.vertices = grid_vertices<dim>(cells, box_min, box_max);
  m.fe = std::make_unique<FESystem<dim>>(FE_Q<dim>(1), dim);
  m.linear_fe = std::make_unique<FE_Q<dim>>(1);
  m.mapping = std::make_unique<MappingQ<dim>>(1);
  m.quadrature = std::make_unique<QGauss<dim>>(2);
  m.face_quadrature = std::make_unique<QGauss<dim - 1>>(2);
  for (int d = 0; d < dim; ++d) m.unit_centroid[d] = 0.5;
  return model;
}

template <int dim>
ElasticModel<dim>::~ElasticModel() = default;
template <int dim>
ElasticModel<dim>::ElasticModel(ElasticModel&&) noexcept = default;
template <int dim>
ElasticModel<dim>& ElasticModel<dim>::operator=(ElasticModel&&) noexcept = default;

template <int dim>
std::size_t ElasticModel<dim>::Impl::voxel_index(const Point<dim>& x) const {
  std::size_t idx = 0, stride = 1;
  for (int d = 0; d < dim; ++d) {
    const double h = (grid_max[d] - grid_min[d]) / grid_cells[d];
    long i = static_cast<long>(std::floor((x[d] - grid_min[d]) / h));
    i = std::min(std::max(i, 0L), grid_cells[d] - 1);
    idx += static_cast<std::size_t>(i) * stride;
    stride *= static_cast<std::size_t>(grid_cells[d]);
  }
  return idx;
}

template <int dim>
void ElasticModel<dim>::Impl::ensure_mesh() {
  if (mesh_built) return;
  if (voxel)
    build_voxel_triangulation();
  else
    build_simplex_triangulation();
  dof.reinit(tria);
  dof.distribute_dofs(*fe);  // no renumbering: DoFs stay node-interleaved for AMG "PDE equations"
  mesh_built = true;
}

template <int dim>
void ElasticModel<dim>::Impl::build_voxel_triangulation() {
  std::vector<unsigned> reps(dim);
  for (int d = 0; d < dim; ++d) reps[d] = static_cast<unsigned>(grid_cells[d]);
  GridGenerator::subdivided_hyper_rectangle(tria, reps, grid_min, grid_max);
  // Cell -> voxel index from its centre (iteration order is not assumed).
  for (const auto& cell : tria.active_cell_iterators())
    cell->set_material_id(static_cast<types::material_id>(voxel_index(cell->center())));
  const auto& tv = tria.get_vertices();
  double h = std::numeric_limits<double>::max();
  for (int d = 0; d < dim; ++d) h = std::min(h, (grid_max[d] - grid_min[d]) / grid_cells[d]);
  if (tv.size() != vertices.size())
    throw std::logic_error("voxel_grid: vertex count differs from deal.II's grid");
  for (std::size_t v = 0; v < tv.size(); ++v)
    if ((to_vec<dim>(tv[v]) - vertices[v]).norm() > 1e-9 * h)
      throw std::logic_error(
          "voxel_grid: vertex numbering differs from deal.II's subdivided_hyper_rectangle");
}

template <int dim>
void ElasticModel<dim>::Impl::build_simplex_triangulation() {
  std::vector<Point<dim>> pts(vertices.size());
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = to_point<dim>(vertices[i]);
  std::vector<CellData<dim>> cells(simplices.size(), CellData<dim>(dim + 1));
  for (std::size_t c = 0; c < cells.size(); ++c) {
    for (int k = 0; k <= dim; ++k) cells[c].vertices[k] = static_cast<unsigned>(simplices[c][k]);
    cells[c].material_id = static_cast<types::material_id>(c);
  }
  tria.create_triangulation(pts, cells, SubCellData());
}

// ================================================================================================
// conditions

template <int dim>
void ElasticModel<dim>::Impl::invalidate() {
  assembled = false;
  matrices_assembled = false;
  direct.reset();
  amg.reset();
  K_trilinos.reset();
  distributed.reset();
  method.clear(), prepared_for.clear();
  have_u0 = false;
  columns.clear();
}

template <int dim>
void ElasticModel<dim>::add_dirichlet(const DirichletBC<dim>& bc) {
  const std::string where = "condition on region '" + bc.region.name + "'";
  if (!bc.region.contains)
    throw std::invalid_argument("add_dirichlet: region '" + bc.region.name + "' has no contains() function");
  if (!bc.function && !bc.value.allFinite())
    throw std::invalid_argument("add_dirichlet: value of " + where + " is not finite");
  if (!is_orthonormal<dim>(bc.axes))
    throw std::invalid_argument(
        "add_dirichlet: axes of " + where +
        " are not orthonormal (its columns must be unit, mutually orthogonal directions)");
  impl_->bcs.push_back(bc);
  impl_->invalidate();
}

template <int dim>
void ElasticModel<dim>::add_surface_load(const SurfaceLoad<dim>& load) {
  if (!load.region.contains)
    throw std::invalid_argument("add_surface_load: region '" + load.region.name +
                                "' has no contains() function");
  if (!load.traction.allFinite() || !std::isfinite(load.pressure))
    throw std::invalid_argument("add_surface_load: traction/pressure on region '" + load.region.name +
                                "' is not finite");
  impl_->loads.push_back(load);
  impl_->invalidate();
}

template <int dim>
void ElasticModel<dim>::add_volume_support(const VolumeSupport<dim>& sup) {
  const std::string where = "add_volume_support: support '" + sup.name + "'";
  if (!(sup.stiffness > 0.0) || !std::isfinite(sup.stiffness))
    throw std::invalid_argument(where + ": stiffness must be finite and > 0, got " +
                                std::to_string(sup.stiffness));
  if (sup.points.size() != sup.weights.size())
    throw std::invalid_argument(where + ": " + std::to_string(sup.points.size()) + " points but " +
                                std::to_string(sup.weights.size()) + " weights");
  for (std::size_t i = 0; i < sup.points.size(); ++i)
    if (!sup.points[i].allFinite() || !(sup.weights[i] >= 0.0) || !std::isfinite(sup.weights[i]))
      throw std::invalid_argument(where + ": point " + std::to_string(i) +
                                  " or its weight is not finite (or the weight < 0)");
  check_support_base<dim>(sup.base, sup.points.size(), where);
  impl_->supports.push_back(sup);
  impl_->invalidate();
}

template <int dim>
void ElasticModel<dim>::set_body_force(const Vec<dim>& f) {
  if (!f.allFinite()) throw std::invalid_argument("set_body_force: body force is not finite");
  impl_->body_force = f;
  impl_->invalidate();
}

template <int dim>
unsigned ElasticModel<dim>::n_dofs() const {
  const Impl& m = *impl_;
  if (m.distributed) return static_cast<unsigned>(m.distributed->n_dofs());
  if (m.mesh_built) return static_cast<unsigned>(m.dof.n_dofs());
  // no mesh built yet: dim DoFs per vertex, and per edge for P2
  std::vector<std::pair<int, int>> edges;
  for (const auto& c : m.simplices)
    for (int a = 0; a <= dim && m.degree == 2; ++a)
      for (int b = a + 1; b <= dim; ++b) edges.emplace_back(std::min(c[a], c[b]), std::max(c[a], c[b]));
  std::sort(edges.begin(), edges.end());
  const auto n_edges = static_cast<std::size_t>(std::unique(edges.begin(), edges.end()) - edges.begin());
  return static_cast<unsigned>(dim * (m.vertices.size() + n_edges));
}
template <int dim>
unsigned ElasticModel<dim>::n_cells() const {
  return static_cast<unsigned>(impl_->E.size());
}
template <int dim>
const std::vector<Vec<dim>>& ElasticModel<dim>::vertices() const {
  return impl_->vertices;
}
template <int dim>
const std::vector<double>& ElasticModel<dim>::youngs_modulus() const {
  return impl_->E;
}
template <int dim>
double ElasticModel<dim>::poisson_ratio() const {
  return impl_->nu;
}
template <int dim>
unsigned ElasticModel<dim>::degree() const {
  return impl_->degree;
}

// ================================================================================================
// Dirichlet constraints

template <int dim>
void ElasticModel<dim>::Impl::constrain_point(const Point<dim>& x,
                                              const std::array<types::global_dof_index, dim>& dofs,
                                              AffineConstraints<double>& constraints,
                                              const std::function<void(types::global_dof_index, int)>& hold,
                                              ConstrainedDirections<dim>* constrained) const {
  const Vec<dim> xv = to_vec<dim>(x);
  std::array<bool, dim> held;
  held.fill(false);
  int n_held = 0;
  for (std::size_t b = 0; b < bcs.size() && n_held < dim; ++b) {
    const auto& bc = bcs[b];
    const bool model_axes = bc.axes == Eigen::Matrix<double, dim, dim>::Identity();
    if (!model_axes && n_held > 0) continue;  // along other axes: the whole point or nothing
    bool any = false;
    for (int c = 0; c < dim; ++c) any = any || (bc.components[c] && !held[c]);
    if (!any || !bc.region.contains(xv)) continue;
    const Vec<dim> value = bc.function ? bc.function(xv) : bc.value;
    for (int c = 0; c < dim; ++c)
      if (bc.components[c] && !std::isfinite(value[c]))
        throw std::invalid_argument("Dirichlet condition on region '" + bc.region.name +
                                    "' gives a non-finite value at " + point_text(xv.data(), dim));
    if (model_axes) {
      for (int c = 0; c < dim; ++c) {
        if (!bc.components[c] || held[c]) continue;
        held[c] = true;
        ++n_held;
        constraints.add_line(dofs[c]);
        constraints.set_inhomogeneity(dofs[c], value[c]);
        hold(dofs[c], static_cast<int>(b));
        if (constrained) constrained->emplace_back(xv, Vec<dim>::Unit(c));
      }
      continue;
    }
    // Rows n_w·u = value_w (n_w = axes.col(w), w selected), reduced by Gauss-Jordan elimination with
    // the largest pivot in each row: u_p + Σ_f M(r, f) u_f = h_r on the pivot components p, the other
    // (free) components f of the point stay unknowns.
    Eigen::Matrix<double, dim, dim + 1> M;
    int k = 0;
    for (int w = 0; w < dim; ++w)
      if (bc.components[w]) {
        M.row(k).template head<dim>() = bc.axes.col(w).transpose();
        M(k, dim) = value[w];
        if (constrained) constrained->emplace_back(xv, bc.axes.col(w));
        ++k;
      }
    std::array<int, dim> pivot;
    std::array<bool, dim> is_pivot;
    is_pivot.fill(false);
    for (int r = 0; r < k; ++r) {
      int p = -1;
      for (int c = 0; c < dim; ++c)
        if (!is_pivot[c] && (p < 0 || std::abs(M(r, c)) > std::abs(M(r, p)))) p = c;
      pivot[r] = p;
      is_pivot[p] = true;
      M.row(r) /= M(r, p);
      for (int q = 0; q < k; ++q)
        if (q != r) M.row(q) -= M(q, p) * M.row(r);
    }
    for (int r = 0; r < k; ++r) {
      const types::global_dof_index i = dofs[pivot[r]];
      constraints.add_line(i);
      for (int f = 0; f < dim; ++f)
        if (!is_pivot[f] && M(r, f) != 0.0) constraints.add_entry(i, dofs[f], -M(r, f));
      constraints.set_inhomogeneity(i, M(r, dim));
    }
    for (int c = 0; c < dim; ++c) hold(dofs[c], static_cast<int>(b));
    return;
  }
}

// ================================================================================================
// local systems

template <int dim>
std::unique_ptr<FEValues<dim>> ElasticModel<dim>::Impl::make_fe_values() const {
  return std::make_unique<FEValues<dim>>(*mapping, *fe, *quadrature,
                                         update_values | update_gradients | update_JxW_values);
}
template <int dim>
std::unique_ptr<FEFaceValues<dim>> ElasticModel<dim>::Impl::make_face_values() const {
  return std::make_unique<FEFaceValues<dim>>(*mapping, *fe, *face_quadrature,
                                             update_values | update_normal_vectors | update_JxW_values);
}

template <int dim>
void ElasticModel<dim>::Impl::local_system(const Cell& cell, FEValues<dim>& fv, FEFaceValues<dim>& ffv,
                                           FullMatrix<double>& Ke, Vector<double>& Fe) const {
  const Lame<> law = material().cell(cell->material_id());
  if (voxel)
    local_voxel(cell, fv, law, Ke, Fe);
  else if (degree == 1)
    local_p1(cell, law, Ke, Fe);
  else
    local_quadrature(cell, fv, law, Ke, Fe);
  if (!loads.empty()) add_surface_loads(cell, ffv, Fe);
}

// All voxel cells are the same axis-aligned box: K_e is the material's combination of its two
// reference matrices (stiffness_parts), integrated once on the first cell assembled.
template <int dim>
void ElasticModel<dim>::Impl::local_voxel(const Cell& cell, FEValues<dim>& fv, const Lame<>& law,
                                          FullMatrix<double>& Ke, Vector<double>& Fe) const {
  const unsigned n = fe->n_dofs_per_cell();
  const bool body = body_force.squaredNorm() > 0.0;
  if (!voxel_reference_ready) {
    fv.reinit(cell);
    for (FullMatrix<double>& K : voxel_K_part) K.reinit(n, n);
    voxel_shape_integral.assign(n, 0.0);
    for (unsigned q = 0; q < fv.n_quadrature_points; ++q) {
      const double w = fv.JxW(q);
      for (unsigned i = 0; i < n; ++i) {
        const unsigned ci = fe->system_to_component_index(i).first;
        const Tensor<1, dim> gi = fv.shape_grad(i, q);
        for (unsigned j = 0; j < n; ++j) {
          const unsigned cj = fe->system_to_component_index(j).first;
          const Tensor<1, dim> gj = fv.shape_grad(j, q);
          const std::array<double, 2> part = Law::stiffness_parts(gi, ci, gj, cj);
          voxel_K_part[0](i, j) += part[0] * w;
          voxel_K_part[1](i, j) += part[1] * w;
        }
        voxel_shape_integral[i] += fv.shape_value(i, q) * w;
      }
    }
    voxel_reference_ready = true;
  }
  for (unsigned i = 0; i < n; ++i) {
    for (unsigned j = 0; j < n; ++j)
      Ke(i, j) = Law::combine(law, voxel_K_part[0](i, j), voxel_K_part[1](i, j));
    Fe(i) = body ? body_force[fe->system_to_component_index(i).first] * voxel_shape_integral[i] : 0.0;
  }
}

// P1: constant strain in the cell, so K_e = |τ| Bᵀ C B exactly (the same matrix as the quadrature
// of local_quadrature, without FEValues and its MappingFE).
template <int dim>
void ElasticModel<dim>::Impl::local_p1(const Cell& cell, const Lame<>& law, FullMatrix<double>& Ke,
                                       Vector<double>& Fe) const {
  const unsigned n = fe->n_dofs_per_cell();
  const bool body = body_force.squaredNorm() > 0.0;
  std::array<Tensor<1, dim>, dim + 1> g;
  const double volume = barycentric_gradients<dim>(cell, g);
  for (unsigned i = 0; i < n; ++i) {
    const auto [ci, vi] = fe->system_to_component_index(i);
    const Tensor<1, dim>& gi = g[vi];
    for (unsigned j = i; j < n; ++j) {
      const auto [cj, vj] = fe->system_to_component_index(j);
      const Tensor<1, dim>& gj = g[vj];
      Ke(i, j) = Ke(j, i) = Law::stiffness(law, gi, ci, gj, cj) * volume;
    }
    Fe(i) = body ? body_force[ci] * volume / (dim + 1) : 0.0;
  }
}

template <int dim>
void ElasticModel<dim>::Impl::local_quadrature(const Cell& cell, FEValues<dim>& fv, const Lame<>& law,
                                               FullMatrix<double>& Ke, Vector<double>& Fe) const {
  const unsigned n = fe->n_dofs_per_cell();
  const bool body = body_force.squaredNorm() > 0.0;
  fv.reinit(cell);
  Ke = 0.0;
  Fe = 0.0;
  for (unsigned q = 0; q < fv.n_quadrature_points; ++q) {
    const double w = fv.JxW(q);
    for (unsigned i = 0; i < n; ++i) {
      const unsigned ci = fe->system_to_component_index(i).first;
      const Tensor<1, dim> gi = fv.shape_grad(i, q);
      for (unsigned j = i; j < n; ++j) {
        const unsigned cj = fe->system_to_component_index(j).first;
        const Tensor<1, dim> gj = fv.shape_grad(j, q);
        Ke(i, j) += Law::stiffness(law, gi, ci, gj, cj) * w;
      }
      if (body) Fe(i) += body_force[ci] * fv.shape_value(i, q) * w;
    }
  }
  for (unsigned i = 0; i < n; ++i)
    for (unsigned j = 0; j < i; ++j) Ke(i, j) = Ke(j, i);
}

// Traction t − p n on the boundary faces whose vertices all lie in a load's region.
template <int dim>
void ElasticModel<dim>::Impl::add_surface_loads(const Cell& cell, FEFaceValues<dim>& ffv,
                                                Vector<double>& Fe) const {
  const unsigned n = fe->n_dofs_per_cell();
  for (const unsigned f : cell->face_indices()) {
    if (!cell->face(f)->at_boundary()) continue;
    bool reinit = false;
    for (const auto& load : loads) {
      bool all = true;
      for (const unsigned v : cell->face(f)->vertex_indices())
        if (!load.region.contains(to_vec<dim>(cell->face(f)->vertex(v)))) {
          all = false;
          break;
        }
      if (!all) continue;
      if (!reinit) ffv.reinit(cell, f), reinit = true;
      for (unsigned q = 0; q < ffv.n_quadrature_points; ++q) {
        const Tensor<1, dim> nrm = ffv.normal_vector(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe->system_to_component_index(i).first;
          const double t = load.traction[ci] - load.pressure * nrm[ci];
          Fe(i) += t * ffv.shape_value(i, q) * ffv.JxW(q);
        }
      }
    }
  }
}

// ================================================================================================
// assembly

template <int dim>
void ElasticModel<dim>::Impl::assemble() {
  if (assembled) return;
  Timer timer;
  find_support_points_and_components();
  ConstrainedDirections<dim> constrained = apply_dirichlet_conditions();
  // A volume support holds every component at its sample points: it removes rigid motions too.
  for (const auto& sup : supports)
    for (const auto& x : sup.points)
      for (unsigned c = 0; c < unsigned(dim); ++c) constrained.emplace_back(x, Vec<dim>::Unit(c));
  check_rigid_modes_removed<dim>(constrained, vertices, bcs, MPI_COMM_SELF);
  assembled = true;
  assemble_matrices();
  assemble_seconds = timer.wall_time();
}

template <int dim>
void ElasticModel<dim>::Impl::assemble_matrices() {
  if (matrices_assembled) return;
  assemble_cells();
  assemble_supports(), assemble_support_load();
  matrices_assembled = true;
}

template <int dim>
bool ElasticModel<dim>::Impl::solves_over_ranks() const {
  return solve_comm != MPI_COMM_NULL && dealii::Utilities::MPI::n_mpi_processes(solve_comm) > 1;
}

// Support points and vector components of all DoFs.
template <int dim>
void ElasticModel<dim>::Impl::find_support_points_and_components() {
  const unsigned n = dof.n_dofs();
  support_points.assign(n, Point<dim>());
  if (degree == 1) {
    // P1/Q1: every DoF sits on a vertex (component c of vertex v is vertex_dof_index(v, c))
    for (const auto& cell : dof.active_cell_iterators())
      for (const unsigned v : cell->vertex_indices())
        for (unsigned c = 0; c < unsigned(dim); ++c)
          support_points[cell->vertex_dof_index(v, c)] = cell->vertex(v);
  } else {
    Quadrature<dim> sq(fe->get_unit_support_points());
    FEValues<dim> sv(*mapping, *fe, sq, update_quadrature_points);
    std::vector<types::global_dof_index> idx(fe->n_dofs_per_cell());
    for (const auto& cell : dof.active_cell_iterators()) {
      sv.reinit(cell);
      cell->get_dof_indices(idx);
      for (unsigned i = 0; i < idx.size(); ++i) support_points[idx[i]] = sv.quadrature_point(i);
    }
  }
  dof_component.assign(n, 0);
  vertex_dofs.clear();  // post-processing cache is rebuilt on next use
  std::vector<types::global_dof_index> idx(fe->n_dofs_per_cell());
  for (const auto& cell : dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < idx.size(); ++i) dof_component[idx[i]] = fe->system_to_component_index(i).first;
  }
}

// The Dirichlet constraints at every support point (first condition wins); returns the constrained
// directions for the rigid-mode check.
template <int dim>
ConstrainedDirections<dim> ElasticModel<dim>::Impl::apply_dirichlet_conditions() {
  const unsigned n = dof.n_dofs();
  constraints.clear();
  dof_bc.assign(n, -1);
  ConstrainedDirections<dim> constrained;
  std::vector<char> seen(n, 0);
  std::vector<types::global_dof_index> idx(fe->n_dofs_per_cell());
  std::vector<std::array<types::global_dof_index, dim>> groups;
  const auto hold = [this](types::global_dof_index i, int b) { dof_bc[i] = b; };
  for (const auto& cell : dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    dof_groups<dim>(*fe, idx, groups);
    for (const auto& g : groups) {
      if (seen[g[0]]) continue;
      seen[g[0]] = 1;
      constrain_point(support_points[g[0]], g, constraints, hold, &constrained);
    }
  }
  constraints.close();
  return constrained;
}

template <int dim>
void ElasticModel<dim>::Impl::assemble_cells() {
  const unsigned n = dof.n_dofs();
  DynamicSparsityPattern dsp(n, n);
  DoFTools::make_sparsity_pattern(dof, dsp);
  sparsity.copy_from(dsp);
  K.reinit(sparsity);
  K_full.reinit(sparsity);
  f.reinit(n);
  f_full.reinit(n);
  auto fv = make_fe_values();
  auto ffv = make_face_values();
  const unsigned dpc = fe->n_dofs_per_cell();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& cell : dof.active_cell_iterators()) {
    local_system(cell, *fv, *ffv, Ke, Fe);
    cell->get_dof_indices(idx);
    constraints.distribute_local_to_global(Ke, Fe, idx, K, f);
    K_full.add(idx, Ke);
    f_full.add(idx, Fe);
  }
}

// Volume supports (VolumeSupport): k w_p N_i(x_p) N_j(x_p) for DoFs i, j of the same component, added to
// K (not to K_full: the strain energy and the Dirichlet reactions stay those of the elastic body).
// Points are grouped by their cell, one FEValues per cell.
template <int dim>
void ElasticModel<dim>::Impl::assemble_supports() {
  f_support.reinit(0);  // f is new: no base load in it yet (assemble_support_load adds it)
  support_outside = 0;
  K_support.clear();
  if (supports.empty()) return;
  K_support.reinit(sparsity);
  const unsigned dpc = fe->n_dofs_per_cell();
  std::map<std::pair<int, int>, std::pair<std::vector<Point<dim>>, std::vector<double>>> by_cell;
  for (const auto& sup : supports)
    for (std::size_t p = 0; p < sup.points.size(); ++p) {
      if (sup.weights[p] == 0.0) continue;
      const auto found = locate(to_point<dim>(sup.points[p]));
      if (found.first == tria.end()) {
        ++support_outside;
        continue;
      }
      auto& e = by_cell[{found.first->level(), found.first->index()}];
      e.first.push_back(found.second);
      e.second.push_back(sup.stiffness * sup.weights[p]);
    }
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& [key, pts] : by_cell) {
    const Cell cell(&tria, key.first, key.second, &dof);
    Quadrature<dim> q(pts.first);
    FEValues<dim> fv(*mapping, *fe, q, update_values);
    fv.reinit(cell);
    Ke = 0.0;
    Fe = 0.0;
    for (unsigned k = 0; k < q.size(); ++k)
      for (unsigned i = 0; i < dpc; ++i) {
        const unsigned ci = fe->system_to_component_index(i).first;
        const double vi = fv.shape_value(i, k) * pts.second[k];
        if (vi == 0.0) continue;
        for (unsigned j = 0; j < dpc; ++j)
          if (fe->system_to_component_index(j).first == ci) Ke(i, j) += vi * fv.shape_value(j, k);
      }
    cell->get_dof_indices(idx);
    constraints.distribute_local_to_global(Ke, Fe, idx, K, f);
    K_support.add(idx, Ke);
  }
}

template <int dim>
std::size_t ElasticModel<dim>::memory_consumption() const {
  const Impl& m = *impl_;
  std::size_t columns = 0;
  for (const auto& [key, e] : m.columns.entries) columns += e.col.memory_consumption();
  return m.tria.memory_consumption() + m.dof.memory_consumption() + m.constraints.memory_consumption() +
         m.sparsity.memory_consumption() + m.K.memory_consumption() + m.K_full.memory_consumption() +
         m.f.memory_consumption() + m.f_full.memory_consumption() + m.u0.memory_consumption() +
         m.u.memory_consumption() + columns +
         dealii::MemoryConsumption::memory_consumption(m.support_points) +
         dealii::MemoryConsumption::memory_consumption(m.dof_bc) +
         dealii::MemoryConsumption::memory_consumption(m.dof_component) +
         (m.distributed ? m.distributed->memory_consumption() : 0);
}

template <int dim>
std::size_t ElasticModel<dim>::cells_held() const {
  const Impl& m = *impl_;
  return (m.mesh_built ? m.tria.n_active_cells() : 0) + (m.distributed ? m.distributed->cells_held() : 0);
}

template class ElasticModel<2>;
template class ElasticModel<3>;

}  // namespace vim::fem

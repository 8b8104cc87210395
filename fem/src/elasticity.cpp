// Small-strain linear elasticity with deal.II (paper §VI-C, DESIGN.md §4/§5), serial part:
// triangulation from a SimplexMesh (P1/P2 simplices) or a voxel grid (Q1 hexahedra), per-cell
// Lamé parameters, Dirichlet regions, surface loads, body force, and embedded point constraints.
//
// Point constraints C u = g (rows = shape-function values at the point) are handled two ways:
//  * solve(): K (Dirichlet eliminated) is factorised ONCE (UMFPACK) and u0 = K⁻¹f kept; columns
//    K⁻¹cᵀ are cached per (position, component). Then S = C K⁻¹ Cᵀ (m×m dense),
//    μ = S⁻¹(C u0 − g), u = u0 − K⁻¹Cᵀ μ: a new constraint costs one back-substitution.
//    On the AMG path each column is one CG solve with the same AMG preconditioner.
//  * solve_monolithic(): the saddle-point system [K Cᵀ; C 0] assembled sparse and solved by UMFPACK.
// Both satisfy K u + Cᵀ μ = f; the force of the constraint on the body is −Cᵀμ (point_force = −μ).
#include "elasticity_impl.hpp"

#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/base/quadrature_lib.h>

#include <Eigen/Dense>
#include <Epetra_MultiVector.h>
#include <Teuchos_ParameterList.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace vim::fem {

using namespace dealii;

namespace {

template <int dim>
Point<dim> to_point(const Vec<dim>& v) {
  Point<dim> p;
  for (int d = 0; d < dim; ++d) p[d] = v[d];
  return p;
}
template <int dim>
Vec<dim> to_vec(const Point<dim>& p) {
  Vec<dim> v;
  for (int d = 0; d < dim; ++d) v[d] = p[d];
  return v;
}

template <int dim>
Tensor<1, dim> to_tensor(const Vec<dim>& v) {
  Tensor<1, dim> t;
  for (int d = 0; d < dim; ++d) t[d] = v[d];
  return t;
}

std::string fmt_point(const double* x, int dim) {
  std::ostringstream s;
  s << "(";
  for (int d = 0; d < dim; ++d) s << (d ? ", " : "") << x[d];
  s << ")";
  return s.str();
}

void check_poisson(double nu) {
  if (!(nu > -1.0 && nu < 0.5)) {
    std::ostringstream m;
    m << "Poisson ratio " << nu << " is outside (-1, 0.5)";
    throw std::invalid_argument(m.str());
  }
}

void check_moduli(const std::vector<double>& E, std::size_t n_cells, const char* what) {
  if (E.size() != n_cells) {
    std::ostringstream m;
    m << what << ": " << E.size() << " Young's moduli given for " << n_cells << " cells";
    throw std::invalid_argument(m.str());
  }
  for (std::size_t j = 0; j < E.size(); ++j)
    if (!std::isfinite(E[j]) || !(E[j] > 0.0)) {
      std::ostringstream m;
      m << what << ": Young's modulus of cell " << j << " is " << E[j] << "; it must be finite and > 0";
      throw std::invalid_argument(m.str());
    }
}

// Rejects degenerate cells (|volume| tiny against the longest edge), faces shared by more than two
// cells, and inverted cells: two cells sharing a face whose opposite vertices lie on the SAME side
// of it overlap (a tangled mesh). A mesh whose cells are merely listed with the other orientation
// is fine: deal.II's invert_cells_with_negative_measure reorders those.
template <int dim>
void check_simplex_mesh(const SimplexMesh<dim>& mesh) {
  if (mesh.cells.empty()) throw std::invalid_argument("ElasticModel: the mesh has no cells");
  const int np = static_cast<int>(mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    if (!mesh.points[i].allFinite())
      throw std::invalid_argument("ElasticModel: mesh vertex " + std::to_string(i) + " has a non-finite coordinate");
  std::vector<double> vol(mesh.cells.size());
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    for (int k = 0; k <= dim; ++k)
      if (mesh.cells[c][k] < 0 || mesh.cells[c][k] >= np) {
        std::ostringstream m;
        m << "ElasticModel: cell " << c << " refers to vertex " << mesh.cells[c][k] << "; valid are 0.." << np - 1;
        throw std::invalid_argument(m.str());
      }
    const auto x = cell_points(mesh, c);
    double h = 0.0;
    for (int a = 0; a <= dim; ++a)
      for (int b = a + 1; b <= dim; ++b) h = std::max(h, (x[a] - x[b]).norm());
    vol[c] = signed_volume<dim>(x);
    if (!(std::abs(vol[c]) > 1e-10 * std::pow(h, dim))) {
      std::ostringstream m;
      m << "ElasticModel: cell " << c << " is degenerate (volume " << vol[c] << ", longest edge " << h << ")";
      throw std::invalid_argument(m.str());
    }
  }
  // Faces (sorted vertex ids) with the side of the opposite vertex, bucketed by their smallest
  // vertex (counting sort, linear, instead of a hash map of all faces); equal faces are found by
  // sorting each small bucket. The error reported is the first offending (cell, face) in cell order,
  // as in a sequential scan: the second cell on a face whose opposite vertices lie on the same side
  // (inverted), or the third cell on a face (non-manifold).
  struct Face {
    std::array<int, dim> v;
    int side;         // sign of the opposite vertex's side
    std::size_t pos;  // cell·(dim+1) + local face
  };
  std::vector<std::size_t> start(static_cast<std::size_t>(np) + 1, 0);
  for (const auto& cell : mesh.cells)
    for (int k = 0; k <= dim; ++k) {
      int lowest = np;
      for (int i = 0; i <= dim; ++i)
        if (i != k) lowest = std::min(lowest, cell[i]);
      ++start[static_cast<std::size_t>(lowest) + 1];
    }
  for (int v = 0; v < np; ++v) start[v + 1] += start[v];
  std::vector<Face> faces(mesh.cells.size() * (dim + 1));
  {
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (std::size_t c = 0; c < mesh.cells.size(); ++c)
      for (int k = 0; k <= dim; ++k) {
        Face f;
        for (int i = 0, j = 0; i <= dim; ++i)
          if (i != k) f.v[j++] = mesh.cells[c][i];
        std::sort(f.v.begin(), f.v.end());
        std::array<Vec<dim>, dim + 1> x;
        for (int i = 0; i < dim; ++i) x[i] = mesh.points[f.v[i]];
        x[dim] = mesh.points[mesh.cells[c][k]];
        f.side = signed_volume<dim>(x) > 0.0 ? 1 : -1;
        f.pos = c * (dim + 1) + static_cast<std::size_t>(k);
        faces[next[f.v[0]]++] = f;
      }
  }
  const std::size_t none = std::numeric_limits<std::size_t>::max();
  std::size_t bad = none, bad_first = 0;
  bool bad_inverted = false;
  for (int v = 0; v < np; ++v) {
    const auto b = faces.begin() + static_cast<std::ptrdiff_t>(start[v]);
    const auto e = faces.begin() + static_cast<std::ptrdiff_t>(start[v + 1]);
    std::sort(b, e, [](const Face& x, const Face& y) { return x.v != y.v ? x.v < y.v : x.pos < y.pos; });
    for (auto g = b; g != e;) {
      auto h = g + 1;
      while (h != e && h->v == g->v) ++h;
      if (h - g >= 2 && g[1].side == g[0].side) {
        if (g[1].pos < bad) bad = g[1].pos, bad_first = g[0].pos, bad_inverted = true;
      } else if (h - g >= 3 && g[2].pos < bad) {
        bad = g[2].pos, bad_inverted = false;
      }
      g = h;
    }
  }
  if (bad == none) return;
  const std::size_t c = bad / (dim + 1);
  if (!bad_inverted)
    throw std::invalid_argument("ElasticModel: cell " + std::to_string(c) +
                                " shares a face with two other cells (non-manifold mesh)");
  std::ostringstream m;
  m << "ElasticModel: cell " << c << " is inverted: it overlaps cell " << bad_first / (dim + 1)
    << " across their shared face (tangled mesh)";
  throw std::invalid_argument(m.str());
}

template <int dim>
std::array<double, dim> key_of(const Vec<dim>& x) {
  std::array<double, dim> k;
  for (int d = 0; d < dim; ++d) k[d] = x[d];
  return k;
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
    throw std::invalid_argument("ElasticModel: element degree " + std::to_string(degree) + " is not supported; use 1 or 2");
  check_poisson(poisson_ratio);
  check_moduli(youngs_modulus, mesh.cells.size(), "ElasticModel");
  check_simplex_mesh(mesh);
  if (mesh.cells.size() >= numbers::invalid_material_id)
    throw std::invalid_argument("ElasticModel: too many cells");
  Impl& m = *impl_;
  m.E = std::move(youngs_modulus);
  m.nu = poisson_ratio;
  m.degree = degree;
  m.vertices.assign(mesh.points.begin(), mesh.points.end());

  std::vector<Point<dim>> pts(mesh.points.size());
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = to_point<dim>(mesh.points[i]);
  std::vector<CellData<dim>> cells(mesh.cells.size(), CellData<dim>(dim + 1));
  for (std::size_t c = 0; c < cells.size(); ++c) {
    for (int k = 0; k <= dim; ++k) cells[c].vertices[k] = static_cast<unsigned>(mesh.cells[c][k]);
    cells[c].material_id = static_cast<types::material_id>(c);
  }
  GridTools::invert_cells_with_negative_measure(pts, cells);
  m.tria.create_triangulation(pts, cells, SubCellData());

  m.fe = std::make_unique<FESystem<dim>>(FE_SimplexP<dim>(degree), dim);
  m.linear_fe = std::make_unique<FE_SimplexP<dim>>(1);
  m.mapping = std::make_unique<MappingFE<dim>>(FE_SimplexP<dim>(1));
  m.quadrature = std::make_unique<QGaussSimplex<dim>>(degree + 1);
  m.face_quadrature = std::make_unique<QGaussSimplex<dim - 1>>(degree + 1);
  for (int d = 0; d < dim; ++d) m.unit_centroid[d] = 1.0 / (dim + 1);
  m.mesh_built = true;  // DoFs on first serial use (ensure_mesh): solve_distributed does not need them
}

template <int dim>
ElasticModel<dim> ElasticModel<dim>::voxel_grid(const std::array<long, dim>& cells, const Vec<dim>& box_min,
                                                const Vec<dim>& box_max, std::vector<double> youngs_modulus,
                                                double poisson_ratio) {
  std::size_t n = 1;
  for (int d = 0; d < dim; ++d) {
    if (cells[d] < 1) {
      std::ostringstream m;
      m << "voxel_grid: " << cells[d] << " cells along axis " << d << "; need >= 1";
      throw std::invalid_argument(m.str());
    }
    if (!std::isfinite(box_min[d]) || !std::isfinite(box_max[d]) || !(box_max[d] > box_min[d])) {
      std::ostringstream m;
      m << "voxel_grid: box [" << box_min[d] << ", " << box_max[d] << "] along axis " << d << " is empty or not finite";
      throw std::invalid_argument(m.str());
    }
    n *= static_cast<std::size_t>(cells[d]);
  }
  check_poisson(poisson_ratio);
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
  // Grid vertices in lexicographic order (axis 0 fastest), the numbering subdivided_hyper_rectangle
  // uses (ensure_mesh checks it).
  std::array<long, dim> nv;
  std::size_t n_vertices = 1;
  for (int d = 0; d < dim; ++d) nv[d] = cells[d] + 1, n_vertices *= static_cast<std::size_t>(nv[d]);
  m.vertices.resize(n_vertices);
  for (std::size_t v = 0; v < n_vertices; ++v) {
    std::size_t r = v;
    for (int d = 0; d < dim; ++d) {
      const long i = static_cast<long>(r % static_cast<std::size_t>(nv[d]));
      r /= static_cast<std::size_t>(nv[d]);
      m.vertices[v][d] = box_min[d] + i * ((box_max[d] - box_min[d]) / cells[d]);
    }
  }
  m.fe = std::make_unique<FESystem<dim>>(FE_Q<dim>(1), dim);
  m.linear_fe = std::make_unique<FE_Q<dim>>(1);
  m.mapping = std::make_unique<MappingQ<dim>>(1);
  m.quadrature = std::make_unique<QGauss<dim>>(2);
  m.face_quadrature = std::make_unique<QGauss<dim - 1>>(2);
  for (int d = 0; d < dim; ++d) m.unit_centroid[d] = 0.5;
  return model;
}

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
  if (mesh_built) {
    if (!dofs_ready) setup_dofs();
    return;
  }
  std::vector<unsigned> reps(dim);
  for (int d = 0; d < dim; ++d) reps[d] = static_cast<unsigned>(grid_cells[d]);
  GridGenerator::subdivided_hyper_rectangle(tria, reps, grid_min, grid_max);
  // Cell -> voxel index from its centre (iteration order is not assumed).
  for (const auto& cell : tria.active_cell_iterators())
    cell->set_material_id(static_cast<types::material_id>(voxel_index(cell->center())));
  const auto& tv = tria.get_vertices();
  double h = std::numeric_limits<double>::max();
  for (int d = 0; d < dim; ++d) h = std::min(h, (grid_max[d] - grid_min[d]) / grid_cells[d]);
  if (tv.size() != vertices.size()) throw std::logic_error("voxel_grid: vertex count differs from deal.II's grid");
  for (std::size_t v = 0; v < tv.size(); ++v)
    if ((to_vec<dim>(tv[v]) - vertices[v]).norm() > 1e-9 * h)
      throw std::logic_error("voxel_grid: vertex numbering differs from deal.II's subdivided_hyper_rectangle");
  setup_dofs();
  mesh_built = true;
}

template <int dim>
ElasticModel<dim>::~ElasticModel() = default;
template <int dim>
ElasticModel<dim>::ElasticModel(ElasticModel&&) noexcept = default;
template <int dim>
ElasticModel<dim>& ElasticModel<dim>::operator=(ElasticModel&&) noexcept = default;

template <int dim>
void ElasticModel<dim>::Impl::setup_dofs() {
  dof.reinit(tria);
  dof.distribute_dofs(*fe);  // no renumbering: DoFs stay node-interleaved for AMG "PDE equations"
  cache = std::make_unique<GridTools::Cache<dim>>(tria, *mapping);
  dofs_ready = true;
}

// ================================================================================================
// conditions

namespace {
template <class Impl>
void invalidate(Impl& m) {
  m.assembled = false;
  m.direct.reset();
  m.amg.reset();
  m.K_trilinos.reset();
  m.method.clear();
  m.have_u0 = false;
  m.columns.clear();
}
}  // namespace

template <int dim>
void ElasticModel<dim>::add_dirichlet(const DirichletBC<dim>& bc) {
  if (!bc.region.contains) throw std::invalid_argument("add_dirichlet: region '" + bc.region.name + "' has no contains() function");
  if (!bc.function && !bc.value.allFinite())
    throw std::invalid_argument("add_dirichlet: value of condition on region '" + bc.region.name + "' is not finite");
  if (!bc.axes.allFinite() ||
      !(bc.axes.transpose() * bc.axes).isApprox(Eigen::Matrix<double, dim, dim>::Identity(), 1e-9))
    throw std::invalid_argument("add_dirichlet: axes of condition on region '" + bc.region.name +
                                "' are not orthonormal (its columns must be unit, mutually orthogonal directions)");
  impl_->bcs.push_back(bc);
  invalidate(*impl_);
}

template <int dim>
void ElasticModel<dim>::add_surface_load(const SurfaceLoad<dim>& load) {
  if (!load.region.contains) throw std::invalid_argument("add_surface_load: region '" + load.region.name + "' has no contains() function");
  if (!load.traction.allFinite() || !std::isfinite(load.pressure))
    throw std::invalid_argument("add_surface_load: traction/pressure on region '" + load.region.name + "' is not finite");
  impl_->loads.push_back(load);
  invalidate(*impl_);
}

template <int dim>
void ElasticModel<dim>::add_volume_support(const VolumeSupport<dim>& sup) {
  const std::string where = "add_volume_support: support '" + sup.name + "'";
  if (!(sup.stiffness > 0.0) || !std::isfinite(sup.stiffness))
    throw std::invalid_argument(where + ": stiffness must be finite and > 0, got " + std::to_string(sup.stiffness));
  if (sup.points.size() != sup.weights.size())
    throw std::invalid_argument(where + ": " + std::to_string(sup.points.size()) + " points but " +
                                std::to_string(sup.weights.size()) + " weights");
  for (std::size_t i = 0; i < sup.points.size(); ++i)
    if (!sup.points[i].allFinite() || !(sup.weights[i] >= 0.0) || !std::isfinite(sup.weights[i]))
      throw std::invalid_argument(where + ": point " + std::to_string(i) + " or its weight is not finite (or the weight < 0)");
  impl_->supports.push_back(sup);
  invalidate(*impl_);
}

template <int dim>
std::size_t ElasticModel<dim>::volume_support_points_outside() const {
  return impl_->support_outside;
}

template <int dim>
void ElasticModel<dim>::set_body_force(const Vec<dim>& f) {
  if (!f.allFinite()) throw std::invalid_argument("set_body_force: body force is not finite");
  impl_->body_force = f;
  invalidate(*impl_);
}

template <int dim>
unsigned ElasticModel<dim>::n_dofs() const {
  Impl& m = *impl_;
  if (m.dofs_ready) return static_cast<unsigned>(m.dof.n_dofs());
  if (m.voxel) return static_cast<unsigned>(dim * m.vertices.size());  // grid not built yet: Q1, dim per vertex
  m.ensure_mesh();
  return static_cast<unsigned>(m.dof.n_dofs());
}
template <int dim>
unsigned ElasticModel<dim>::n_cells() const { return static_cast<unsigned>(impl_->E.size()); }
template <int dim>
const std::vector<Vec<dim>>& ElasticModel<dim>::vertices() const { return impl_->vertices; }
template <int dim>
const std::vector<double>& ElasticModel<dim>::youngs_modulus() const { return impl_->E; }
template <int dim>
double ElasticModel<dim>::poisson_ratio() const { return impl_->nu; }
template <int dim>
unsigned ElasticModel<dim>::degree() const { return impl_->degree; }

// ================================================================================================
// assembly

namespace {

// Unit vector along model axis c.
template <int dim>
Tensor<1, dim> unit_axis(unsigned c) {
  Tensor<1, dim> e;
  e[c] = 1.0;
  return e;
}

}  // namespace

template <int dim>
void ElasticModel<dim>::Impl::constrain_point(const Point<dim>& x, const std::array<types::global_dof_index, dim>& dofs,
                                              AffineConstraints<double>& constraints,
                                              const std::function<void(types::global_dof_index, int)>& hold,
                                              std::vector<std::pair<Point<dim>, Tensor<1, dim>>>* constrained) const {
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
        throw std::invalid_argument("Dirichlet condition on region '" + bc.region.name + "' gives a non-finite value at " +
                                    fmt_point(xv.data(), dim));
    if (model_axes) {
      for (int c = 0; c < dim; ++c) {
        if (!bc.components[c] || held[c]) continue;
        held[c] = true;
        ++n_held;
        constraints.add_line(dofs[c]);
        constraints.set_inhomogeneity(dofs[c], value[c]);
        hold(dofs[c], static_cast<int>(b));
        if (constrained) constrained->emplace_back(x, unit_axis<dim>(c));
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
        if (constrained) constrained->emplace_back(x, to_tensor<dim>(bc.axes.col(w)));
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

// The conditions remove every rigid motion iff no rigid mode r ≠ 0 vanishes on all constrained
// DoFs, i.e. the Gram matrix Σ_i r_k(i) r_l(i) over constrained DoFs is non-singular.
template <int dim>
void ElasticModel<dim>::Impl::check_rigid_modes_removed(const std::vector<std::pair<Point<dim>, Tensor<1, dim>>>& constrained,
                                                        MPI_Comm comm) const {
  const auto n_constrained = Utilities::MPI::sum(static_cast<unsigned long long>(constrained.size()), comm);
  if (n_constrained == 0) {
    std::ostringstream m;
    m << "no Dirichlet condition constrains any node (";
    if (bcs.empty()) m << "none was added";
    else {
      m << "regions:";
      for (const auto& bc : bcs) m << " '" << bc.region.name << "'";
      m << " select no node";
    }
    m << "): the stiffness matrix is singular; fix part of the boundary";
    throw std::runtime_error(m.str());
  }
  constexpr int nm = dim == 2 ? 3 : 6;
  // rotations about the bounding-box centre, scaled to unit size (the same on every rank)
  Vec<dim> lo = vertices[0], hi = vertices[0];
  for (const auto& v : vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const Point<dim> c0 = to_point<dim>(0.5 * (lo + hi));
  const double scale = std::max(0.5 * (hi - lo).norm(), std::numeric_limits<double>::min());
  Eigen::Matrix<double, nm, nm> G = Eigen::Matrix<double, nm, nm>::Zero();
  for (const auto& [x, n] : constrained) {
    // The constrained direction n seen by each rigid mode: translations n, rotations ω·(r × n).
    const Tensor<1, dim> r = (x - c0) / scale;
    Eigen::Matrix<double, nm, 1> row = Eigen::Matrix<double, nm, 1>::Zero();
    for (int d = 0; d < dim; ++d) row[d] = n[d];
    if constexpr (dim == 2) {
      row[2] = -r[1] * n[0] + r[0] * n[1];
    } else {
      const Tensor<1, 3> rn = cross_product_3d(r, n);
      for (int a = 0; a < 3; ++a) row[3 + a] = rn[a];
    }
    G += row * row.transpose();
  }
  Utilities::MPI::sum(ArrayView<const double>(G.data(), nm * nm), comm, ArrayView<double>(G.data(), nm * nm));
  const auto constrained_size = n_constrained;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, nm, nm>> es(G);
  if (!(es.eigenvalues()[0] > 1e-10 * std::max(1.0, es.eigenvalues()[nm - 1]))) {
    std::ostringstream m;
    m << "the Dirichlet conditions constrain " << constrained_size
      << " DoFs but leave a rigid-body motion free (e.g. only one component or one line fixed): "
         "the stiffness matrix is singular; constrain enough components/nodes";
    throw SingularConstraints(m.str());
  }
}

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
void ElasticModel<dim>::Impl::local_system(const typename DoFHandler<dim>::active_cell_iterator& cell,
                                           FEValues<dim>& fv, FEFaceValues<dim>& ffv, FullMatrix<double>& Ke,
                                           Vector<double>& Fe) const {
  const unsigned n = fe->n_dofs_per_cell();
  const auto [lambda, mu] = lame_parameters(E[cell->material_id()], nu);
  const bool body = body_force.squaredNorm() > 0.0;
  if (voxel) {
    // all voxel cells are the same axis-aligned box: scale the two reference matrices
    if (!voxel_reference_ready) {
      fv.reinit(cell);
      voxel_K_lambda.reinit(n, n);
      voxel_K_mu.reinit(n, n);
      voxel_shape_integral.assign(n, 0.0);
      for (unsigned q = 0; q < fv.n_quadrature_points; ++q) {
        const double w = fv.JxW(q);
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe->system_to_component_index(i).first;
          const Tensor<1, dim> gi = fv.shape_grad(i, q);
          for (unsigned j = 0; j < n; ++j) {
            const unsigned cj = fe->system_to_component_index(j).first;
            const Tensor<1, dim> gj = fv.shape_grad(j, q);
            voxel_K_lambda(i, j) += gi[ci] * gj[cj] * w;
            voxel_K_mu(i, j) += (gi[cj] * gj[ci] + (ci == cj ? gi * gj : 0.0)) * w;
          }
          voxel_shape_integral[i] += fv.shape_value(i, q) * w;
        }
      }
      voxel_reference_ready = true;
    }
    for (unsigned i = 0; i < n; ++i) {
      for (unsigned j = 0; j < n; ++j) Ke(i, j) = lambda * voxel_K_lambda(i, j) + mu * voxel_K_mu(i, j);
      Fe(i) = body ? body_force[fe->system_to_component_index(i).first] * voxel_shape_integral[i] : 0.0;
    }
  } else if (degree == 1) {
    // P1: constant strain in the cell, so K_e = |τ| Bᵀ C B exactly (the same matrix as the
    // quadrature below, without FEValues and its MappingFE).
    std::array<Tensor<1, dim>, dim + 1> g;
    const double volume = barycentric_gradients<dim>(cell, g);
    for (unsigned i = 0; i < n; ++i) {
      const auto [ci, vi] = fe->system_to_component_index(i);
      const Tensor<1, dim>& gi = g[vi];
      for (unsigned j = i; j < n; ++j) {
        const auto [cj, vj] = fe->system_to_component_index(j);
        const Tensor<1, dim>& gj = g[vj];
        double v = lambda * gi[ci] * gj[cj] + mu * gi[cj] * gj[ci];
        if (ci == cj) v += mu * (gi * gj);
        Ke(i, j) = Ke(j, i) = v * volume;
      }
      Fe(i) = body ? body_force[ci] * volume / (dim + 1) : 0.0;
    }
  } else {
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
        double v = lambda * gi[ci] * gj[cj] + mu * gi[cj] * gj[ci];
        if (ci == cj) v += mu * (gi * gj);
        Ke(i, j) += v * w;
      }
      if (body) Fe(i) += body_force[ci] * fv.shape_value(i, q) * w;
    }
  }
  for (unsigned i = 0; i < n; ++i)
    for (unsigned j = 0; j < i; ++j) Ke(i, j) = Ke(j, i);
  }
  if (loads.empty()) return;
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

namespace {
template <int dim, class Impl>
std::pair<typename Triangulation<dim>::active_cell_iterator, Point<dim>> locate(const Impl& m, const Point<dim>& x,
                                                                             bool* verified_first);

// Volume supports (VolumeSupport): k w_p N_i(x_p) N_j(x_p) for DoFs i, j of the same component, added to
// K (not to K_full: the strain energy and the Dirichlet reactions stay those of the elastic body).
// Points are grouped by their cell, one FEValues per cell.
template <int dim, class Impl>
void assemble_supports(Impl& m) {
  m.support_outside = 0;
  if (m.supports.empty()) return;
  const FiniteElement<dim>& fe = *m.fe;
  const unsigned dpc = fe.n_dofs_per_cell();
  std::map<std::pair<int, int>, std::pair<std::vector<Point<dim>>, std::vector<double>>> by_cell;
  for (const auto& sup : m.supports)
    for (std::size_t p = 0; p < sup.points.size(); ++p) {
      if (sup.weights[p] == 0.0) continue;
      const auto found = locate<dim>(m, to_point<dim>(sup.points[p]), nullptr);
      if (found.first == m.tria.end()) {
        ++m.support_outside;
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
    const typename DoFHandler<dim>::active_cell_iterator cell(&m.tria, key.first, key.second, &m.dof);
    Quadrature<dim> q(pts.first);
    FEValues<dim> fv(*m.mapping, fe, q, update_values);
    fv.reinit(cell);
    Ke = 0.0;
    Fe = 0.0;
    for (unsigned k = 0; k < q.size(); ++k)
      for (unsigned i = 0; i < dpc; ++i) {
        const unsigned ci = fe.system_to_component_index(i).first;
        const double vi = fv.shape_value(i, k) * pts.second[k];
        if (vi == 0.0) continue;
        for (unsigned j = 0; j < dpc; ++j)
          if (fe.system_to_component_index(j).first == ci) Ke(i, j) += vi * fv.shape_value(j, k);
      }
    cell->get_dof_indices(idx);
    m.constraints.distribute_local_to_global(Ke, Fe, idx, m.K, m.f);
  }
}

template <int dim, class Impl>
void assemble(Impl& m) {
  if (m.assembled) return;
  Timer timer;
  const unsigned n = m.dof.n_dofs();
  const FiniteElement<dim>& fe = *m.fe;
  // Support points of all DoFs, then Dirichlet constraints (first condition wins).
  m.support_points.assign(n, Point<dim>());
  if (m.degree == 1) {
    // P1/Q1: every DoF sits on a vertex (component c of vertex v is vertex_dof_index(v, c))
    for (const auto& cell : m.dof.active_cell_iterators())
      for (const unsigned v : cell->vertex_indices())
        for (unsigned c = 0; c < unsigned(dim); ++c) m.support_points[cell->vertex_dof_index(v, c)] = cell->vertex(v);
  } else {
    Quadrature<dim> sq(fe.get_unit_support_points());
    FEValues<dim> sv(*m.mapping, fe, sq, update_quadrature_points);
    std::vector<types::global_dof_index> idx(fe.n_dofs_per_cell());
    for (const auto& cell : m.dof.active_cell_iterators()) {
      sv.reinit(cell);
      cell->get_dof_indices(idx);
      for (unsigned i = 0; i < idx.size(); ++i) m.support_points[idx[i]] = sv.quadrature_point(i);
    }
  }
  std::vector<unsigned>& component = m.dof_component;
  component.assign(n, 0);
  m.vertex_dofs.clear();  // post-processing cache is rebuilt on next use
  {
    std::vector<types::global_dof_index> idx(fe.n_dofs_per_cell());
    for (const auto& cell : m.dof.active_cell_iterators()) {
      cell->get_dof_indices(idx);
      for (unsigned i = 0; i < idx.size(); ++i) component[idx[i]] = fe.system_to_component_index(i).first;
    }
  }
  m.constraints.clear();
  m.dof_bc.assign(n, -1);
  std::vector<std::pair<Point<dim>, Tensor<1, dim>>> constrained;
  {
    std::vector<char> seen(n, 0);
    std::vector<types::global_dof_index> idx(fe.n_dofs_per_cell());
    std::vector<std::array<types::global_dof_index, dim>> groups;
    const auto hold = [&m](types::global_dof_index i, int b) { m.dof_bc[i] = b; };
    for (const auto& cell : m.dof.active_cell_iterators()) {
      cell->get_dof_indices(idx);
      dof_groups<dim>(fe, idx, groups);
      for (const auto& g : groups) {
        if (seen[g[0]]) continue;
        seen[g[0]] = 1;
        m.constrain_point(m.support_points[g[0]], g, m.constraints, hold, &constrained);
      }
    }
  }
  m.constraints.close();
  // A volume support holds every component at its sample points: it removes rigid motions too.
  for (const auto& sup : m.supports)
    for (const auto& x : sup.points)
      for (unsigned c = 0; c < unsigned(dim); ++c) constrained.emplace_back(to_point<dim>(x), unit_axis<dim>(c));
  m.check_rigid_modes_removed(constrained);

  DynamicSparsityPattern dsp(n, n);
  DoFTools::make_sparsity_pattern(m.dof, dsp);
  m.sparsity.copy_from(dsp);
  m.K.reinit(m.sparsity);
  m.K_full.reinit(m.sparsity);
  m.f.reinit(n);
  m.f_full.reinit(n);

  auto fv = m.make_fe_values();
  auto ffv = m.make_face_values();
  const unsigned dpc = fe.n_dofs_per_cell();
  FullMatrix<double> Ke(dpc, dpc);
  Vector<double> Fe(dpc);
  std::vector<types::global_dof_index> idx(dpc);
  for (const auto& cell : m.dof.active_cell_iterators()) {
    m.local_system(cell, *fv, *ffv, Ke, Fe);
    cell->get_dof_indices(idx);
    m.constraints.distribute_local_to_global(Ke, Fe, idx, m.K, m.f);
    m.K_full.add(idx, Ke);
    m.f_full.add(idx, Fe);
  }
  assemble_supports<dim>(m);
  m.assembled = true;
  m.assemble_seconds = timer.wall_time();
}

}  // namespace

// ================================================================================================
// solving

UmfpackLU::UmfpackLU(const SparseMatrix<double>& K) {
  const auto n = static_cast<SuiteSparse_long>(K.m());
  // K is symmetric, so its rows (CSR) are its columns (CSC); UMFPACK wants sorted indices.
  Ap.assign(n + 1, 0);
  for (SuiteSparse_long i = 0; i < n; ++i) Ap[i + 1] = Ap[i] + static_cast<SuiteSparse_long>(K.get_row_length(i));
  Ai.resize(Ap[n]);
  Ax.resize(Ap[n]);
  std::vector<std::pair<SuiteSparse_long, double>> row;
  for (SuiteSparse_long i = 0; i < n; ++i) {
    row.clear();
    for (auto it = K.begin(i); it != K.end(i); ++it) row.emplace_back(static_cast<SuiteSparse_long>(it->column()), it->value());
    std::sort(row.begin(), row.end());
    for (std::size_t k = 0; k < row.size(); ++k) Ai[Ap[i] + k] = row[k].first, Ax[Ap[i] + k] = row[k].second;
  }
  umfpack_dl_defaults(control);
  control[UMFPACK_STRATEGY] = UMFPACK_STRATEGY_SYMMETRIC;
  control[UMFPACK_IRSTEP] = 0;
  double info[UMFPACK_INFO];
  int status = umfpack_dl_symbolic(n, n, Ap.data(), Ai.data(), Ax.data(), &symbolic, control, info);
  if (status == UMFPACK_OK) status = umfpack_dl_numeric(Ap.data(), Ai.data(), Ax.data(), symbolic, &numeric, control, info);
  if (status != UMFPACK_OK) {
    if (symbolic) umfpack_dl_free_symbolic(&symbolic);
    if (numeric) umfpack_dl_free_numeric(&numeric);
    throw std::runtime_error("UMFPACK factorisation of the stiffness matrix failed (status " + std::to_string(status) +
                             (status == UMFPACK_WARNING_singular_matrix ? ": singular matrix)" : ")"));
  }
  Wi.resize(n);
  W.resize(n);
  b.resize(n);
}

UmfpackLU::~UmfpackLU() {
  if (symbolic) umfpack_dl_free_symbolic(&symbolic);
  if (numeric) umfpack_dl_free_numeric(&numeric);
}

void UmfpackLU::solve(Vector<double>& x) const {
  std::copy(x.begin(), x.end(), b.begin());
  double info[UMFPACK_INFO];
  const int status = umfpack_dl_wsolve(UMFPACK_A, Ap.data(), Ai.data(), Ax.data(), x.data(), b.data(), numeric,
                                       control, info, Wi.data(), W.data());
  if (status != UMFPACK_OK) throw std::runtime_error("UMFPACK solve failed (status " + std::to_string(status) + ")");
}

namespace {

// Trilinos (the AMG preconditioner and its matrix) needs MPI initialised even on one process. Test
// mains and MPI programs do that through deal.II's MPI_InitFinalize; a serial program such as the
// CLI does not, so the first serial AMG set-up initialises MPI itself and finalises it at exit.
void ensure_mpi_initialized() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) return;
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("the AMG solver needs MPI, and MPI_Init_thread failed; use solver type 'direct'");
  std::atexit([] {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  });
}

template <int dim, class Impl>
void prepare_solver(Impl& m, const SolverOptions& opt) {
  if (!(opt.tolerance > 0.0) || !std::isfinite(opt.tolerance))
    throw std::invalid_argument("SolverOptions: tolerance must be finite and > 0, got " + std::to_string(opt.tolerance));
  if (opt.max_iterations == 0) throw std::invalid_argument("SolverOptions: max_iterations must be > 0");
  assemble<dim>(m);
  const bool use_amg = opt.type == SolverOptions::Type::amg ||
                       (opt.type == SolverOptions::Type::automatic && m.dof.n_dofs() > opt.direct_limit_for(dim));
  const std::string method = use_amg ? "cg+amg" : "umfpack";
  if (m.method == method) return;
  m.direct.reset();
  m.amg.reset();
  m.K_trilinos.reset();
  m.have_u0 = false;
  m.columns.clear();
  Timer timer;
  if (!use_amg) {
    m.direct = std::make_unique<UmfpackLU>(m.K);
  } else {
    ensure_mpi_initialized();
    m.K_trilinos = std::make_unique<TrilinosWrappers::SparseMatrix>();
    m.K_trilinos->reinit(m.K, 0.0);
    // centre the rotations at the bounding-box centre for conditioning
    Point<dim> lo = m.support_points[0], hi = lo;
    for (const auto& p : m.support_points)
      for (int d = 0; d < dim; ++d) lo[d] = std::min(lo[d], p[d]), hi[d] = std::max(hi[d], p[d]);
    const Point<dim> mid = 0.5 * (lo + hi);
    std::vector<unsigned> comp(m.dof.n_dofs());
    std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
    for (const auto& cell : m.dof.active_cell_iterators()) {
      cell->get_dof_indices(idx);
      for (unsigned i = 0; i < idx.size(); ++i) comp[idx[i]] = m.fe->system_to_component_index(i).first;
    }
    m.amg = std::make_unique<TrilinosWrappers::PreconditionAMG>();
    amg_setup<dim>(*m.K_trilinos, [&](unsigned i) { return Point<dim>(m.support_points[i] - mid); },
                   [&](unsigned i) { return comp[i]; }, m.degree, m.voxel, *m.amg);
  }
  m.prepare_seconds = timer.wall_time();
  m.method = method;
}

// x = K⁻¹ b with the prepared solver; returns CG iterations (0 for the direct solver).
template <class Impl>
unsigned apply_inverse(const Impl& m, const Vector<double>& b, Vector<double>& x, const SolverOptions& opt,
                       double* residual = nullptr) {
  if (m.direct) {
    x = b;
    m.direct->solve(x);
    if (residual) *residual = 0.0;
    return 0;
  }
  x.reinit(b.size());
  const double bn = b.l2_norm();
  if (bn == 0.0) return 0;
  SolverControl control(opt.max_iterations, opt.tolerance * bn);
  SolverCG<Vector<double>> cg(control);
  try {
    cg.solve(*m.K_trilinos, x, b, *m.amg);
  } catch (const SolverControl::NoConvergence& e) {
    std::ostringstream s;
    s << "CG+AMG did not converge in " << e.last_step << " iterations (relative residual "
      << e.last_residual / bn << ", tolerance " << opt.tolerance << ")";
    throw std::runtime_error(s.str());
  }
  if (residual) *residual = control.last_value() / bn;
  return control.last_step();
}

// The cell containing x and x's reference coordinates, or (end, ·) if x is outside the mesh.
// find_active_cell_around_point's answer is verified (reference coordinates inside the reference
// cell, and mapping back to x); if it fails, all cells are searched (as a last resort only).
template <int dim, class Impl>
std::pair<typename Triangulation<dim>::active_cell_iterator, Point<dim>> locate(const Impl& m, const Point<dim>& x,
                                                                             bool* verified_first) {
  const double tol = 1e-10;
  auto ok = [&](const typename Triangulation<dim>::active_cell_iterator& cell, const Point<dim>& xi) {
    if (!cell->reference_cell().contains_point(xi, tol)) return false;
    const Point<dim> back = m.mapping->transform_unit_to_real_cell(cell, xi);
    return back.distance(x) <= 1e-9 * std::max(1.0, cell->diameter());
  };
  try {
    const auto found = GridTools::find_active_cell_around_point(*m.cache, x);
    if (found.first.state() == IteratorState::valid && found.first != m.tria.end() && ok(found.first, found.second)) {
      if (verified_first) *verified_first = true;
      return found;
    }
  } catch (...) {
  }
  if (verified_first) *verified_first = false;
  for (const auto& cell : m.tria.active_cell_iterators()) {
    // cheap bounding-box rejection first
    const auto box = cell->bounding_box();
    bool in = true;
    for (int d = 0; d < dim; ++d) {
      const double pad = 1e-9 * cell->diameter();
      in = in && x[d] >= box.get_boundary_points().first[d] - pad && x[d] <= box.get_boundary_points().second[d] + pad;
    }
    if (!in) continue;
    try {
      const Point<dim> xi = m.mapping->transform_real_to_unit_cell(cell, x);
      if (ok(cell, xi)) return {cell, xi};
    } catch (...) {
    }
  }
  return {m.tria.end(), Point<dim>()};
}

// Row of C for direction a (a unit vector; e_c for component c) at the point x: a[k] times the
// shape-function values of component k in the containing cell, Dirichlet DoFs moved to the
// right-hand side. `c` only names the component in messages.
template <int dim, class Impl>
ConstraintRow constraint_row(const Impl& m, const Vec<dim>& x, const Vec<dim>& a, unsigned c, double g, std::size_t which) {
  const auto found = locate<dim>(m, to_point<dim>(x), nullptr);
  if (found.first == m.tria.end()) {
    std::ostringstream s;
    s << "point constraint " << which << " at " << fmt_point(x.data(), dim) << " lies outside the mesh";
    throw std::invalid_argument(s.str());
  }
  const typename DoFHandler<dim>::active_cell_iterator cell(&m.tria, found.first->level(), found.first->index(), &m.dof);
  Quadrature<dim> q(std::vector<Point<dim>>{found.second});
  FEValues<dim> fv(*m.mapping, *m.fe, q, update_values);
  fv.reinit(cell);
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  cell->get_dof_indices(idx);
  ConstraintRow row;
  row.g = g;
  double scale = 0.0;
  for (unsigned i = 0; i < idx.size(); ++i) {
    const double v = a[m.fe->system_to_component_index(i).first] * fv.shape_value(i, 0);
    scale = std::max(scale, std::abs(v));
    if (v == 0.0) continue;
    if (m.dof_bc[idx[i]] >= 0) {  // for the reactions: the row's own coefficients on held DoFs
      row.dirichlet_dofs.push_back(idx[i]);
      row.dirichlet_values.push_back(v);
    }
    if (const auto* entries = m.constraints.get_constraint_entries(idx[i])) {
      // u_i = h + Σ a_f u_f (a support along other axes): h moves to g, v·a_f onto the free DoFs f.
      row.g -= v * m.constraints.get_inhomogeneity(idx[i]);
      for (const auto& [f, a] : *entries) {
        auto at = std::find(row.dofs.begin(), row.dofs.end(), f);
        if (at == row.dofs.end()) {
          row.dofs.push_back(f);
          row.values.push_back(v * a);
        } else {
          row.values[static_cast<std::size_t>(at - row.dofs.begin())] += v * a;
        }
      }
    } else {
      auto at = std::find(row.dofs.begin(), row.dofs.end(), idx[i]);
      if (at == row.dofs.end()) {
        row.dofs.push_back(idx[i]);
        row.values.push_back(v);
      } else {
        row.values[static_cast<std::size_t>(at - row.dofs.begin())] += v;
      }
    }
  }
  double free_scale = 0.0;
  for (double v : row.values) free_scale = std::max(free_scale, std::abs(v));
  if (!(free_scale > 1e-12 * scale)) {
    if (std::abs(row.g) > 1e-12 * (1.0 + std::abs(g))) {
      std::ostringstream s;
      s << "point constraint " << which << " at " << fmt_point(x.data(), dim) << " (component " << c
        << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
      throw std::invalid_argument(s.str());
    }
    row.active = false;
  }
  return row;
}

// Greedy, in the given order: a row numerically in the span of earlier kept rows is not kept.
std::vector<bool> independent_rows(const std::vector<const ConstraintRow*>& rows) {
  std::unordered_map<types::global_dof_index, int> col;
  for (const auto* r : rows)
    for (auto d : r->dofs) col.emplace(d, static_cast<int>(col.size()));
  std::vector<Eigen::VectorXd> basis;
  std::vector<bool> keep(rows.size(), false);
  for (std::size_t a = 0; a < rows.size(); ++a) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(col.size()));
    for (std::size_t i = 0; i < rows[a]->dofs.size(); ++i) v[col[rows[a]->dofs[i]]] += rows[a]->values[i];
    const double n0 = v.norm();
    for (int pass = 0; pass < 2; ++pass)
      for (const auto& b : basis) v -= b.dot(v) * b;
    if (v.norm() > 1e-9 * n0) {
      keep[a] = true;
      basis.push_back(v / v.norm());
    }
  }
  return keep;
}

// Dropped (dependent) rows must hold for the solution anyway; otherwise they conflict.
void check_dropped_rows(const std::vector<const ConstraintRow*>& rows, const std::vector<double>& g,
                        const std::vector<bool>& keep, const std::vector<std::pair<std::size_t, unsigned>>& which,
                        const Vector<double>& u) {
  double scale = u.linfty_norm();
  for (double v : g) scale = std::max(scale, std::abs(v));
  for (std::size_t a = 0; a < rows.size(); ++a) {
    if (keep[a]) continue;
    double cu = 0.0;
    for (std::size_t i = 0; i < rows[a]->dofs.size(); ++i) cu += rows[a]->values[i] * u[rows[a]->dofs[i]];
    if (std::abs(cu - g[a]) > 1e-8 * scale) {
      std::ostringstream s;
      s << "point constraint " << which[a].first << " (component " << which[a].second
        << ") conflicts with earlier point constraints: it is a linear combination of them (e.g. a third point "
           "on a line inside one P1 element, or a repeated point) but asks for a different displacement "
           "(misfit " << cu - g[a] << ")";
      throw DependentPointConstraints(s.str());
    }
  }
}

template <int dim>
void check_points(const std::vector<PointConstraint<dim>>& points) {
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!points[k].position.allFinite() || !points[k].displacement.allFinite())
      throw std::invalid_argument("point constraint " + std::to_string(k) + " has a non-finite position or displacement");
    if (!points[k].axes.allFinite() ||
        !(points[k].axes.transpose() * points[k].axes).isApprox(Eigen::Matrix<double, dim, dim>::Identity(), 1e-9))
      throw std::invalid_argument("point constraint " + std::to_string(k) +
                                  " has axes that are not orthonormal (its columns must be unit, mutually orthogonal directions)");
  }
}

}  // namespace

namespace {

// Vertex displacement, centroid strain/stress, energy, reactions from m.u.
template <int dim, class Impl>
void build_post_cache(Impl& m) {
  const unsigned dpc = m.fe->n_dofs_per_cell();
  const unsigned ns = m.fe->base_element(0).n_dofs_per_cell();
  const std::size_t nc = m.tria.n_active_cells();
  m.vertex_dofs.assign(m.tria.n_vertices(), {});
  const double bytes = double(nc) * (dpc * sizeof(types::global_dof_index) + ns * dim * sizeof(double));
  m.post_cache = bytes < 400e6;
  if (m.post_cache) {
    m.cell_dofs.resize(nc * dpc);
    m.centroid_grads.resize(nc * ns * dim);
    m.cell_index.resize(nc);
  }
  Quadrature<dim> cq(std::vector<Point<dim>>{m.unit_centroid});
  FEValues<dim> cv(*m.mapping, *m.fe, cq, update_gradients);
  std::size_t k = 0;
  for (const auto& cell : m.dof.active_cell_iterators()) {
    for (const unsigned v : cell->vertex_indices())
      for (unsigned c = 0; c < unsigned(dim); ++c) m.vertex_dofs[cell->vertex_index(v)][c] = cell->vertex_dof_index(v, c);
    if (m.post_cache) {
      cv.reinit(cell);
      std::vector<types::global_dof_index> idx(dpc);
      cell->get_dof_indices(idx);
      std::copy(idx.begin(), idx.end(), m.cell_dofs.begin() + k * dpc);
      // the scalar basis gradient: take the component-0 copy of each scalar function
      for (unsigned i = 0; i < dpc; ++i) {
        const auto [c, sidx] = m.fe->system_to_component_index(i);
        if (c != 0) continue;
        const Tensor<1, dim> g = cv.shape_grad(i, 0);
        for (int d = 0; d < dim; ++d) m.centroid_grads[(k * ns + sidx) * dim + d] = g[d];
      }
      m.cell_index[k] = cell->material_id();
    }
    ++k;
  }
}

// Vertex displacement, centroid strain/stress, energy, reactions from m.u.
template <int dim, class Impl>
Solution<dim> postprocess(Impl& m) {
  Solution<dim> s;
  const Vector<double>& u = m.u;
  if (m.vertex_dofs.empty()) build_post_cache<dim>(m);
  s.vertex_displacement.resize(m.tria.n_vertices());
  for (std::size_t v = 0; v < m.vertex_dofs.size(); ++v)
    for (int c = 0; c < dim; ++c) s.vertex_displacement[v][c] = u[m.vertex_dofs[v][c]];
  const unsigned nc = m.tria.n_active_cells();
  s.cell_strain.assign(nc, Eigen::Matrix<double, dim, dim>::Zero());
  s.cell_stress.assign(nc, Eigen::Matrix<double, dim, dim>::Zero());
  s.von_mises.assign(nc, 0.0);
  const unsigned dpc = m.fe->n_dofs_per_cell();
  const unsigned ns = m.fe->base_element(0).n_dofs_per_cell();
  if (m.post_cache) {
    std::vector<unsigned> comp(dpc), scalar(dpc);
    for (unsigned i = 0; i < dpc; ++i)
      comp[i] = m.fe->system_to_component_index(i).first, scalar[i] = m.fe->system_to_component_index(i).second;
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
  } else {
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
  Vector<double> Ku(u.size());
  m.K_full.vmult(Ku, u);
  s.strain_energy = 0.5 * (u * Ku);
  s.dirichlet_reaction.assign(m.bcs.size(), Vec<dim>::Zero());
  for (unsigned i = 0; i < u.size(); ++i)
    if (m.dof_bc[i] >= 0) s.dirichlet_reaction[m.dof_bc[i]][m.dof_component[i]] += Ku[i] - m.f_full[i];
  s.stats.n_dofs = m.dof.n_dofs();
  s.stats.assemble_seconds = m.assemble_seconds;
  return s;
}

// The full system reads K u = f + r − Cᵀμ on every DoF (r: support reactions), so on Dirichlet
// DoFs r = K u − f + C_Dᵀ μ: add the constraint rows' Dirichlet parts to the reactions.
template <int dim, class Impl>
void add_constraint_reactions(const Impl& m, const ConstraintRow& row, double mu, Solution<dim>& s) {
  for (std::size_t i = 0; i < row.dirichlet_dofs.size(); ++i) {
    const auto d = row.dirichlet_dofs[i];
    const int b = m.dof_bc[d];
    if (b >= 0) s.dirichlet_reaction[b][m.dof_component[d]] += mu * row.dirichlet_values[i];
  }
}

// After a constrained solve of m.u (free DoFs): checks the dropped rows, distributes the Dirichlet
// values and post-processes; the point forces are left zero for the caller to fill in.
template <int dim, class Impl>
Solution<dim> finish_constrained_solve(Impl& m, const std::vector<const ConstraintRow*>& rows,
                                       const std::vector<double>& g, const std::vector<bool>& keep,
                                       const std::vector<std::pair<std::size_t, unsigned>>& which,
                                       std::size_t n_points, const Timer& timer, double* solve_seconds) {
  check_dropped_rows(rows, g, keep, which, m.u);
  m.constraints.distribute(m.u);
  m.have_solution = true;
  *solve_seconds = timer.wall_time();
  Solution<dim> s = postprocess<dim>(m);
  s.point_force.assign(n_points, Vec<dim>::Zero());
  return s;
}

}  // namespace

template <int dim>
Eigen::Matrix<double, dim, dim> ElasticModel<dim>::Impl::centroid_strain(
    const typename DoFHandler<dim>::active_cell_iterator& cell, FEValues<dim>& cv, const std::vector<double>& ue) const {
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

template <int dim>
void ElasticModel<dim>::Impl::stress_of(const Eigen::Matrix<double, dim, dim>& eps, double E_cell,
                                        Eigen::Matrix<double, dim, dim>& sigma, double& von_mises) const {
  const auto [lambda, mu] = lame_parameters(E_cell, nu);
  const double tr = eps.trace();
  sigma = 2.0 * mu * eps;
  for (int d = 0; d < dim; ++d) sigma(d, d) += lambda * tr;
  // full 3×3 stress; in 2D (plane strain) σ_zz = λ tr ε
  Eigen::Matrix3d s3 = Eigen::Matrix3d::Zero();
  s3.topLeftCorner<dim, dim>() = sigma;
  if (dim == 2) s3(2, 2) = lambda * tr;
  const Eigen::Matrix3d dev = s3 - s3.trace() / 3.0 * Eigen::Matrix3d::Identity();
  von_mises = std::sqrt(1.5 * (dev.array() * dev.array()).sum());
}

template <int dim>
Solution<dim> ElasticModel<dim>::solve(const std::vector<PointConstraint<dim>>& points, const SolverOptions& opt) {
  Impl& m = *impl_;
  check_points(points);
  m.ensure_mesh();
  prepare_solver<dim>(m, opt);
  Timer timer;
  unsigned iterations = 0;
  double residual = 0.0;
  if (!m.have_u0) {
    m.u0_iterations = apply_inverse(m, m.f, m.u0, opt, &residual);
    m.have_u0 = true;
  }
  iterations += m.u0_iterations;
  // Rows (cached with their columns K⁻¹cᵀ per (position, component)).
  struct Active {
    const ConstraintRow* row;
    const Vector<double>* col;
    double g;
    std::size_t point;
    unsigned comp;
  };
  std::vector<Active> rows;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c) {
      if (!points[k].components[c]) continue;
      const Vec<dim> dir = points[k].axes.col(c);
      const typename Impl::Key key{key_of<dim>(points[k].position), key_of<dim>(dir)};
      auto it = m.columns.find(key);
      if (it == m.columns.end()) {
        ConstraintRow row = constraint_row<dim>(m, points[k].position, dir, c, 0.0, k);
        Vector<double> col;
        if (row.active) {
          Vector<double> e(m.dof.n_dofs());
          for (std::size_t i = 0; i < row.dofs.size(); ++i) e[row.dofs[i]] = row.values[i];
          iterations += apply_inverse(m, e, col, opt);
        }
        it = m.columns.emplace(key, std::make_pair(std::move(row), std::move(col))).first;
      }
      // g of the cached row holds −c_D·u_D only; add the requested displacement now.
      const double g = points[k].displacement[c] + it->second.first.g;
      if (!it->second.first.active) {
        if (std::abs(g) > 1e-12 * (1.0 + std::abs(points[k].displacement[c]))) {
          std::ostringstream s;
          s << "point constraint " << k << " (component " << c
            << ") lies on Dirichlet-constrained nodes and asks for a different displacement";
          throw std::invalid_argument(s.str());
        }
        continue;
      }
      rows.push_back({&it->second.first, &it->second.second, g, k, c});
    }
  std::vector<const ConstraintRow*> all_rows;
  std::vector<double> all_g;
  std::vector<std::pair<std::size_t, unsigned>> all_which;
  for (const auto& r : rows) all_rows.push_back(r.row), all_g.push_back(r.g), all_which.emplace_back(r.point, r.comp);
  // S = C K⁻¹ Cᵀ over all rows; a row is dropped (in order) when its pivot in an ordered Cholesky
  // of S vanishes: it is then a combination of the earlier kept rows (sin² of the angle < 1e-10 in
  // the K⁻¹ metric). Checked for consistency after the solve.
  const std::size_t n_all = rows.size();
  Eigen::MatrixXd S_all(n_all, n_all);
  Eigen::VectorXd r_all(n_all);
  for (std::size_t a = 0; a < n_all; ++a) {
    const ConstraintRow& ra = *rows[a].row;
    double cu = 0.0;
    for (std::size_t i = 0; i < ra.dofs.size(); ++i) cu += ra.values[i] * m.u0[ra.dofs[i]];
    r_all[a] = cu - rows[a].g;
    for (std::size_t b = 0; b < n_all; ++b) {
      double v = 0.0;
      for (std::size_t i = 0; i < ra.dofs.size(); ++i) v += ra.values[i] * (*rows[b].col)[ra.dofs[i]];
      S_all(a, b) = v;
    }
  }
  S_all = 0.5 * (S_all + S_all.transpose()).eval();
  std::vector<bool> keep(n_all, false);
  std::vector<Eigen::Index> kept;
  {
    Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n_all, n_all);  // Cholesky rows of the kept set
    for (std::size_t a = 0; a < n_all; ++a) {
      const Eigen::Index k = static_cast<Eigen::Index>(kept.size());
      Eigen::VectorXd l(k);
      for (Eigen::Index i = 0; i < k; ++i) {
        double v = S_all(kept[i], a);
        for (Eigen::Index j = 0; j < i; ++j) v -= L(i, j) * l[j];
        l[i] = v / L(i, i);
      }
      const double d = S_all(a, a) - l.squaredNorm();
      if (!(S_all(a, a) > 0.0) || !(d > 1e-10 * S_all(a, a))) continue;
      keep[a] = true;
      for (Eigen::Index j = 0; j < k; ++j) L(k, j) = l[j];
      L(k, k) = std::sqrt(d);
      kept.push_back(static_cast<Eigen::Index>(a));
    }
  }
  std::vector<Active> used;
  for (std::size_t a = 0; a < n_all; ++a)
    if (keep[a]) used.push_back(rows[a]);
  rows.swap(used);
  const std::size_t nr = rows.size();
  m.u = m.u0;
  std::vector<double> mu(nr, 0.0);
  if (nr > 0) {
    Eigen::MatrixXd S(nr, nr);
    Eigen::VectorXd r(nr);
    for (std::size_t a = 0; a < nr; ++a) {
      r[a] = r_all[kept[a]];
      for (std::size_t b = 0; b < nr; ++b) S(a, b) = S_all(kept[a], kept[b]);
    }
    Eigen::LLT<Eigen::MatrixXd> llt(S);  // S = C K⁻¹ Cᵀ is SPD for independent rows
    // Conditioning of S scaled to a unit diagonal: a chain of shaft points along element edges makes
    // it fall geometrically with the chain's length (1e-4 at 8 rows, 1e-18 at 60 along a 2D grid line),
    // while the ordered pivots above need not vanish (cancellation, depending on the processor's
    // rounding). Below 1e-14 the solve's error bound n·ε/rcond exceeds 10% for a few dozen rows: the
    // multipliers (the point forces) and the displacements between the points have no reliable digit
    // in the weakest direction, so the rows are reported as dependent. (Paths along element edges of
    // a 2D grid whose worst step stays at 2e-13 to 8e-13 keep their sampling; the chains that made noise
    // reached 1e-16 to 1e-18.)
    const Eigen::VectorXd dinv = S.diagonal().cwiseSqrt().cwiseInverse();
    const Eigen::LLT<Eigen::MatrixXd> scaled(dinv.asDiagonal() * S * dinv.asDiagonal());
    const double rcond = scaled.info() == Eigen::Success ? scaled.rcond() : 0.0;
    if (!(rcond >= 1e-14)) {
      std::ostringstream s;
      s << "the " << nr << " point-constraint rows are nearly dependent (reciprocal condition number " << rcond
        << " of their Schur complement)";
      throw DependentPointConstraints(s.str());
    }
    if (llt.info() != Eigen::Success) {
      std::ostringstream s;
      s << "the Schur complement of the " << nr << " point-constraint rows is not positive definite (nearly dependent rows)";
      throw DependentPointConstraints(s.str());
    }
    const Eigen::VectorXd x = llt.solve(r);
    for (std::size_t a = 0; a < nr; ++a) {
      mu[a] = x[a];
      m.u.add(-x[a], *rows[a].col);
    }
  }
  double solve_seconds = 0.0;
  Solution<dim> s =
      finish_constrained_solve<dim>(m, all_rows, all_g, keep, all_which, points.size(), timer, &solve_seconds);
  for (std::size_t a = 0; a < nr; ++a) {
    s.point_force[rows[a].point] -= mu[a] * points[rows[a].point].axes.col(rows[a].comp);
    add_constraint_reactions<dim>(m, *rows[a].row, mu[a], s);
  }
  s.stats.method = m.method;
  s.stats.constraint_rows = static_cast<unsigned>(nr);
  s.stats.dependent_rows_dropped = static_cast<unsigned>(n_all - nr);
  s.stats.iterations = iterations;
  s.stats.residual = residual;
  s.stats.solve_seconds = solve_seconds + m.prepare_seconds;
  s.stats.precondition_seconds = m.prepare_seconds;
  m.prepare_seconds = 0.0;  // count factorisation / AMG setup once
  return s;
}

template <int dim>
Solution<dim> ElasticModel<dim>::solve_monolithic(const std::vector<PointConstraint<dim>>& points,
                                                  const SolverOptions& opt) {
  Impl& m = *impl_;
  check_points(points);
  m.ensure_mesh();
  assemble<dim>(m);
  Timer timer;
  const unsigned n = m.dof.n_dofs();
  struct R {
    ConstraintRow row;
    std::size_t point;
    unsigned comp;
  };
  std::vector<R> rows;
  for (std::size_t k = 0; k < points.size(); ++k)
    for (unsigned c = 0; c < unsigned(dim); ++c)
      if (points[k].components[c]) {
        ConstraintRow row = constraint_row<dim>(m, points[k].position, Vec<dim>(points[k].axes.col(c)), c,
                                                points[k].displacement[c], k);
        if (row.active) rows.push_back({std::move(row), k, c});
      }
  std::vector<const ConstraintRow*> all_rows;
  std::vector<double> all_g;
  std::vector<std::pair<std::size_t, unsigned>> all_which;
  for (const auto& r : rows) all_rows.push_back(&r.row), all_g.push_back(r.row.g), all_which.emplace_back(r.point, r.comp);
  const std::vector<bool> keep = independent_rows(all_rows);
  std::vector<R> used;
  for (std::size_t a = 0; a < rows.size(); ++a)
    if (keep[a]) used.push_back(rows[a]);
  const std::size_t n_all = rows.size();
  const unsigned nr = static_cast<unsigned>(used.size());
  DynamicSparsityPattern dsp(n + nr, n + nr);
  for (unsigned i = 0; i < n; ++i)
    for (auto it = m.sparsity.begin(i); it != m.sparsity.end(i); ++it) dsp.add(i, it->column());
  for (unsigned a = 0; a < nr; ++a)
    for (auto d : used[a].row.dofs) dsp.add(n + a, d), dsp.add(d, n + a);
  SparsityPattern sp;
  sp.copy_from(dsp);
  SparseMatrix<double> A(sp);
  for (unsigned i = 0; i < n; ++i)
    for (auto it = m.K.begin(i); it != m.K.end(i); ++it) A.set(i, it->column(), it->value());
  Vector<double> x(n + nr);
  for (unsigned i = 0; i < n; ++i) x[i] = m.f[i];
  for (unsigned a = 0; a < nr; ++a) {
    for (std::size_t i = 0; i < used[a].row.dofs.size(); ++i) {
      A.set(n + a, used[a].row.dofs[i], used[a].row.values[i]);
      A.set(used[a].row.dofs[i], n + a, used[a].row.values[i]);
    }
    x[n + a] = used[a].row.g;
  }
  SparseDirectUMFPACK direct;
  direct.initialize(A);
  direct.solve(x);
  m.u.reinit(n);
  for (unsigned i = 0; i < n; ++i) m.u[i] = x[i];
  double solve_seconds = 0.0;
  Solution<dim> s =
      finish_constrained_solve<dim>(m, all_rows, all_g, keep, all_which, points.size(), timer, &solve_seconds);
  for (unsigned a = 0; a < nr; ++a) {
    s.point_force[used[a].point] -= x[n + a] * points[used[a].point].axes.col(used[a].comp);
    add_constraint_reactions<dim>(m, used[a].row, x[n + a], s);
  }
  s.stats.method = "umfpack-monolithic";
  s.stats.constraint_rows = nr;
  s.stats.dependent_rows_dropped = static_cast<unsigned>(n_all - nr);
  s.stats.solve_seconds = solve_seconds;
  (void)opt;
  return s;
}

// ================================================================================================
// sampling and energies

template <int dim>
std::vector<Vec<dim>> ElasticModel<dim>::sample(const std::vector<Vec<dim>>& points, PointSample* info) const {
  const Impl& m = *impl_;
  if (!m.have_solution) throw std::runtime_error("sample: no solution yet; call solve() first");  // solve() built the mesh
  std::vector<Point<dim>> pts(points.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!points[i].allFinite()) throw std::invalid_argument("sample: point " + std::to_string(i) + " is not finite");
    pts[i] = to_point<dim>(points[i]);
  }
  std::vector<Vec<dim>> out(points.size(), Vec<dim>::Zero());
  std::vector<bool> inside(points.size(), false);
  // compute_point_locations answers in bulk; each answer is verified (see locate) and points it
  // dropped or misplaced are located again one by one.
  const auto [cells, qpoints, maps] = GridTools::compute_point_locations(*m.cache, pts);
  std::vector<std::pair<typename Triangulation<dim>::active_cell_iterator, Point<dim>>> where(
      pts.size(), {m.tria.end(), Point<dim>()});
  for (std::size_t k = 0; k < cells.size(); ++k)
    for (unsigned p = 0; p < qpoints[k].size(); ++p) {
      const unsigned i = maps[k][p];
      const auto& xi = qpoints[k][p];
      if (cells[k]->reference_cell().contains_point(xi, 1e-10) &&
          m.mapping->transform_unit_to_real_cell(cells[k], xi).distance(pts[i]) <= 1e-9 * std::max(1.0, cells[k]->diameter()))
        where[i] = {cells[k], xi};
    }
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (where[i].first == m.tria.end()) where[i] = locate<dim>(m, pts[i], nullptr);
    if (where[i].first == m.tria.end()) continue;
    const typename DoFHandler<dim>::active_cell_iterator cell(&m.tria, where[i].first->level(), where[i].first->index(), &m.dof);
    Quadrature<dim> q(std::vector<Point<dim>>{where[i].second});
    FEValues<dim> fv(*m.mapping, *m.fe, q, update_values);
    fv.reinit(cell);
    cell->get_dof_indices(idx);
    Vec<dim> v = Vec<dim>::Zero();
    for (unsigned j = 0; j < idx.size(); ++j) v[m.fe->system_to_component_index(j).first] += m.u[idx[j]] * fv.shape_value(j, 0);
    out[i] = v;
    inside[i] = true;
  }
  if (info) {
    info->inside = inside;
    info->n_outside = static_cast<std::size_t>(std::count(inside.begin(), inside.end(), false));
  }
  return out;
}

template <int dim>
double ElasticModel<dim>::strain_energy_of(const std::vector<Vec<dim>>& U) const {
  Impl& m = *impl_;
  m.ensure_mesh();
  if (U.size() != m.tria.n_vertices()) {
    std::ostringstream s;
    s << "strain_energy_of: " << U.size() << " vertex values for " << m.tria.n_vertices() << " vertices";
    throw std::invalid_argument(s.str());
  }
  // Element by element (independent of the Dirichlet conditions): Σ ½ u_eᵀ K_e u_e.
  const unsigned n = m.dof.n_dofs();
  Vector<double> u(n);
  const auto& unit = m.fe->get_unit_support_points();
  std::vector<types::global_dof_index> idx(m.fe->n_dofs_per_cell());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < idx.size(); ++i) {
      const unsigned c = m.fe->system_to_component_index(i).first;
      double v = 0.0;
      for (const unsigned k : cell->vertex_indices()) v += m.linear_fe->shape_value(k, unit[i]) * U[cell->vertex_index(k)][c];
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

template class ElasticModel<2>;
template class ElasticModel<3>;

}  // namespace vim::fem

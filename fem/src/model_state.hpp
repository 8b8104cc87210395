// Internal to vim_fem (deal.II inside): the state behind ElasticModel<dim>, shared by its translation
// units — model.cpp (set-up, conditions, assembly), solvers.cpp (UMFPACK, CG+AMG, the point-constraint
// solves), postprocess.cpp (fields, point location, sampling, energies) and distributed.cpp (MPI).
// Weak form (deal.II step-8; paper §VI-C):
//   ∫ λ (∇·u)(∇·v) + 2μ ε(u):ε(v) dx = ∫ b·v dx + ∫_Γ (t − p n)·v ds,   λ, μ per cell from (E_j, ν).
#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>
#include <vim/fem/model.hpp>

#include "cholmod_llt.hpp"
#include "input_checks.hpp"

namespace vim::fem {

// The material (linear_elastic_material.hpp, included by the translation units that assemble or
// evaluate the law, so that only they are rebuilt when it changes).
template <typename Number>
struct Lame;
template <int dim>
class LinearElasticMaterial;

// ---- conversions between the public Eigen types and deal.II's ------------------------------------
template <int dim>
dealii::Point<dim> to_point(const Vec<dim>& v) {
  dealii::Point<dim> p;
  for (int d = 0; d < dim; ++d) p[d] = v[d];
  return p;
}
template <int dim>
Vec<dim> to_vec(const dealii::Point<dim>& p) {
  Vec<dim> v;
  for (int d = 0; d < dim; ++d) v[d] = p[d];
  return v;
}

// Columns are unit vectors, mutually orthogonal (within 1e-9), and finite.
template <int dim>
bool is_orthonormal(const Eigen::Matrix<double, dim, dim>& axes) {
  return axes.allFinite() &&
         (axes.transpose() * axes).isApprox(Eigen::Matrix<double, dim, dim>::Identity(), 1e-9);
}

// Throws std::invalid_argument for a tolerance that is not finite and > 0, or no iterations.
inline void check_solver_options(const SolverOptions& opt) {
  if (!(opt.tolerance > 0.0) || !std::isfinite(opt.tolerance))
    throw std::invalid_argument("SolverOptions: tolerance must be finite and > 0, got " +
                                std::to_string(opt.tolerance));
  if (opt.max_iterations == 0) throw std::invalid_argument("SolverOptions: max_iterations must be > 0");
  if (!(opt.max_memory >= 0.0) || !std::isfinite(opt.max_memory))
    throw std::invalid_argument("SolverOptions: max_memory must be finite and >= 0 bytes, got " +
                                std::to_string(opt.max_memory));
}

// One scalar constraint row c·u = g on the free DoFs (Dirichlet DoFs condensed into g).
struct ConstraintRow {
  std::vector<dealii::types::global_dof_index> dofs;
  std::vector<double> values;
  // the part on Dirichlet DoFs moved to g (for the reactions): each coefficient with the condition
  // holding its DoF and the DoF's component
  std::vector<double> dirichlet_values;
  std::vector<int> dirichlet_bc;
  std::vector<unsigned char> dirichlet_comp;
  double g = 0.0;           // right-hand side after moving Dirichlet contributions over
  bool active = true;       // false: the point sits on Dirichlet DoFs only (the row is void)
  double compliance = 0.0;  // κ of the row: c·u − g = κ·μ (PointConstraint::compliance)
};

// One DoF of the cell holding a point: its index in the numbering of the solve, its component, the value
// of its shape function at the point, and its Dirichlet data — the condition holding it (or −1) and,
// when constrained, u_dof = inhomogeneity + Σ a_f u_f over `entries`.
struct StencilDof {
  dealii::types::global_dof_index dof = 0;
  unsigned comp = 0;
  double shape = 0.0;
  int bc = -1;
  bool constrained = false;
  double inhomogeneity = 0.0;
  std::vector<std::pair<dealii::types::global_dof_index, double>> entries;
};

// What a constraint row needs of a point: the DoFs of its cell with their shape values
// there (empty, inside == false, for a point outside the mesh).
struct PointStencil {
  bool inside = false;
  std::vector<StencilDof> dofs;
};

// The DoFs of a cell grouped by support point: groups[k][c] is the DoF of component c at the k-th
// support point of the base element (FESystem of dim copies of one scalar element).
template <int dim>
void dof_groups(const dealii::FiniteElement<dim>& fe, const std::vector<dealii::types::global_dof_index>& idx,
                std::vector<std::array<dealii::types::global_dof_index, dim>>& groups) {
  groups.resize(fe.n_dofs_per_cell() / dim);
  for (unsigned i = 0; i < idx.size(); ++i) {
    const auto ci = fe.system_to_component_index(i);
    groups[ci.second][ci.first] = idx[i];
  }
}

// P1 simplex: the shape functions are the barycentric coordinates (shape function k of
// FE_SimplexP(1) belongs to cell vertex k), with constant gradients ∇λ_k = row k−1 of J⁻¹ (k ≥ 1) and
// ∇λ_0 = −Σ ∇λ_k, J = [x_1 − x_0, …, x_dim − x_0]. Fills g and returns the cell's volume.
template <int dim, class CellIterator>
double barycentric_gradients(const CellIterator& cell, std::array<dealii::Tensor<1, dim>, dim + 1>& g) {
  dealii::Tensor<2, dim> J;
  const dealii::Point<dim> x0 = cell->vertex(0);
  for (int k = 1; k <= dim; ++k)
    for (int d = 0; d < dim; ++d) J[d][k - 1] = cell->vertex(k)[d] - x0[d];
  const dealii::Tensor<2, dim> Jinv = dealii::invert(J);
  g[0] = dealii::Tensor<1, dim>();
  for (int k = 1; k <= dim; ++k) {
    g[k] = Jinv[k - 1];
    g[0] -= g[k];
  }
  return std::abs(dealii::determinant(J)) / (dim == 2 ? 2.0 : 6.0);
}

// x's reference coordinates in `cell`, when they lie in the reference cell within 1e-10 and map back to
// x (the test that accepts a point location); std::nullopt otherwise.
template <int dim, class CellIterator>
std::optional<dealii::Point<dim>> reference_point(const dealii::Mapping<dim>& mapping,
                                                  const CellIterator& cell, const dealii::Point<dim>& x) {
  try {
    const dealii::Point<dim> xi = mapping.transform_real_to_unit_cell(cell, x);
    if (cell->reference_cell().contains_point(xi, 1e-10) &&
        mapping.transform_unit_to_real_cell(cell, xi).distance(x) <= 1e-9 * std::max(1.0, cell->diameter()))
      return xi;
  } catch (...) {  // the mapping could not invert: x is not in this cell
  }
  return std::nullopt;
}

// The stencil of reference point xi of a DoF cell: its DoFs with their shape values (not mapped: P1/P2
// simplices, Q1 boxes) and Dirichlet data from `constraints` and bc_of(dof) (the condition or −1).
template <int dim, class DofCell, class BcOf>
PointStencil cell_stencil(const dealii::FiniteElement<dim>& fe, const DofCell& cell,
                          const dealii::Point<dim>& xi, const dealii::AffineConstraints<double>& constraints,
                          const BcOf& bc_of) {
  PointStencil st;
  st.inside = true;
  std::vector<dealii::types::global_dof_index> idx(fe.n_dofs_per_cell());
  cell->get_dof_indices(idx);
  st.dofs.resize(idx.size());
  for (unsigned i = 0; i < idx.size(); ++i) {
    StencilDof& d = st.dofs[i];
    d.dof = idx[i];
    d.comp = fe.system_to_component_index(i).first;
    d.shape = fe.shape_value(i, xi);
    d.bc = bc_of(idx[i]);
    d.constrained = constraints.is_constrained(idx[i]);
    if (!d.constrained) continue;
    d.inhomogeneity = constraints.get_inhomogeneity(idx[i]);
    if (const auto* entries = constraints.get_constraint_entries(idx[i])) d.entries = *entries;
  }
  return st;
}

// The value of the field u at reference point xi of a DoF cell.
template <int dim, class DofCell>
Vec<dim> cell_value(const dealii::FiniteElement<dim>& fe, const DofCell& cell, const dealii::Point<dim>& xi,
                    const dealii::Vector<double>& u) {
  std::vector<dealii::types::global_dof_index> idx(fe.n_dofs_per_cell());
  cell->get_dof_indices(idx);
  Vec<dim> v = Vec<dim>::Zero();
  for (unsigned i = 0; i < idx.size(); ++i)
    v[fe.system_to_component_index(i).first] += u[idx[i]] * fe.shape_value(i, xi);
  return v;
}

// The constraint rows whose columns K⁻¹cᵀ have been computed, by key (a row's position, direction, then
// its sample offsets and weights), with c·u0 and the symmetrised products c_a·K⁻¹c_bᵀ of pairs as
// solves need them: after a precomputation a solve with cached rows does only dense work on these.
struct ColumnCache {
  using Key = std::vector<double>;
  struct Entry {
    ConstraintRow row;
    dealii::Vector<double> col;  // K⁻¹cᵀ (empty for an inactive row)
    double cu0 = 0.0;            // c·u0, u0 = K⁻¹f
    std::size_t id = 0;          // index into the Gram matrix
  };
  std::map<Key, Entry> entries;
  // Symmetrised c_a·K⁻¹c_bᵀ by id; NaN: not computed yet. Grown by doubling.
  Eigen::MatrixXd gram;

  void clear() {
    entries.clear();
    gram.resize(0, 0);
  }
  // Adds a row with its column; `u0` gives its c·u0.
  Entry& add(Key key, ConstraintRow row, dealii::Vector<double> col, const dealii::Vector<double>& u0);
  // ½(c_a·K⁻¹c_bᵀ + c_b·K⁻¹c_aᵀ), computed on first use.
  double product(const Entry& a, const Entry& b);
};

// K⁻¹ of a model over MPI ranks (distributed.cpp): vectors in the DoF numbering of the distributed
// system, complete on every rank; no rank builds the serial mesh. Collective: every rank calls each
// function with the same arguments.
template <int dim>
class DistributedInverse {
 public:
  virtual ~DistributedInverse() = default;
  // x = K⁻¹ b, or x = K⁻¹ f (the model's load, assembled on the ranks) for b == nullptr; returns the
  // CG iterations and sets *residual (relative) when given.
  virtual unsigned apply(const dealii::Vector<double>* b, dealii::Vector<double>& x, const SolverOptions& opt,
                         double* residual) = 0;
  // The vertex displacement, cell strain, stress and von Mises, strain energy and Dirichlet reactions
  // of the displacement u (Dirichlet values in), each rank computing its own cells.
  virtual Solution<dim> fields(const dealii::Vector<double>& u) = 0;
  // The stencils of points x_i in cells c_i (material ids; −1: outside), each computed by the rank
  // owning its cell and shared with all.
  virtual std::vector<PointStencil> stencils(const std::vector<std::pair<long, dealii::Point<dim>>>& at) = 0;
  // The values of u (complete on every rank) at the same kind of points, each computed by the rank
  // owning its cell; std::nullopt for a point outside.
  virtual std::vector<std::optional<Vec<dim>>> values(
      const std::vector<std::pair<long, dealii::Point<dim>>>& at, const dealii::Vector<double>& u) = 0;
  // Sets the Dirichlet-constrained entries of u from the free ones and the conditions.
  virtual void distribute_constraints(dealii::Vector<double>& u) = 0;
  virtual dealii::types::global_dof_index n_dofs() const = 0;
  virtual std::size_t memory_consumption() const = 0;
  // The rank's owned and ghost cells.
  virtual std::size_t cells_held() const = 0;
  // "mumps (mpi, N ranks)" or "cg+amg (mpi, N ranks)", and why (SolverStats::reason).
  virtual const std::string& method() const = 0;
  virtual const std::string& reason() const = 0;
};

template <int dim>
struct ElasticModel<dim>::Impl {
  using Key = ColumnCache::Key;
  using Cell = typename dealii::DoFHandler<dim>::active_cell_iterator;
  using Located = std::pair<typename dealii::Triangulation<dim>::active_cell_iterator, dealii::Point<dim>>;

  // ---- input -------------------------------------------------------------------------------
  bool voxel = false;
  // Voxel models: the grid (cells per axis, box). The serial triangulation/DoFHandler of every model is
  // built on first serial use (ensure_mesh); distributed solves build their own distributed mesh from
  // the grid or the input simplices instead, so no rank of an MPI solve holds the whole mesh.
  std::array<long, dim> grid_cells{};
  dealii::Point<dim> grid_min, grid_max;
  bool mesh_built = false;  // the serial triangulation and its DoFs (ensure_mesh)
  // Voxel cells are congruent boxes: K_e combines the material's two reference matrices
  // (Law::stiffness_parts) per cell, and ∫N_i, from the first cell assembled.
  mutable bool voxel_reference_ready = false;
  mutable std::array<dealii::FullMatrix<double>, 2> voxel_K_part;
  mutable std::vector<double> voxel_shape_integral;
  std::vector<Vec<dim>> vertices;
  // simplex models: the input cells, each positively oriented (vertex order reversed if needed)
  std::vector<typename SimplexMesh<dim>::Cell> simplices;
  std::vector<double> E;  // per input cell (material_id of a deal.II cell = its input index)
  double nu = 0.3;
  // The material of the cells (fem/src/linear_elastic_material.hpp): a view of E and ν.
  using Law = LinearElasticMaterial<dim>;
  Law material() const;
  unsigned degree = 1;
  std::vector<DirichletBC<dim>> bcs;
  std::vector<SurfaceLoad<dim>> loads;
  std::vector<VolumeSupport<dim>> supports;
  std::size_t support_outside = 0;  // support points outside the mesh (set by assemble)
  Vec<dim> body_force = Vec<dim>::Zero();

  // ---- discretisation ----------------------------------------------------------------------
  dealii::Triangulation<dim> tria;
  std::unique_ptr<dealii::FESystem<dim>> fe;
  std::unique_ptr<dealii::FiniteElement<dim>> linear_fe;  // scalar P1 / Q1: vertex interpolation
  std::unique_ptr<dealii::Mapping<dim>> mapping;
  std::unique_ptr<dealii::Quadrature<dim>> quadrature;
  std::unique_ptr<dealii::Quadrature<dim - 1>> face_quadrature;
  dealii::Point<dim> unit_centroid;
  dealii::DoFHandler<dim> dof;

  // ---- point location (built on first use) -------------------------------------------------
  mutable std::unique_ptr<CellLocator<dim>> locator;
  // the deal.II cell of each locator cell (index = material id = input cell / voxel index)
  mutable std::vector<typename dealii::Triangulation<dim>::active_cell_iterator> cell_of_index;

  // ---- assembled system (serial) -----------------------------------------------------------
  bool assembled = false;           // support points, DoF components and conditions, constraints
  bool matrices_assembled = false;  // K, K_full, f, f_full (not built while K⁻¹ runs over ranks)
  std::vector<dealii::Point<dim>> support_points;  // per DoF
  std::vector<int> dof_bc;                         // per DoF: owning DirichletBC or -1
  std::vector<unsigned> dof_component;             // per DoF: vector component
  // Post-processing cache (built on first use when it fits in ~400 MB): per cell, its DoFs and the
  // gradients of the scalar basis functions at the centroid; per vertex, its DoFs.
  bool post_cache = false;
  std::vector<dealii::types::global_dof_index> cell_dofs;
  std::vector<double> centroid_grads;
  std::vector<unsigned> cell_index;  // material id = input cell index
  std::vector<std::array<dealii::types::global_dof_index, dim>> vertex_dofs;
  dealii::AffineConstraints<double> constraints;
  dealii::SparsityPattern sparsity;
  dealii::SparseMatrix<double> K;       // Dirichlet DoFs eliminated (symmetric)
  dealii::SparseMatrix<double> K_full;  // unconstrained: energy ½uᵀKu and reactions Ku − f
  dealii::Vector<double> f, f_full;
  // The volume supports alone, unconstrained (sparsity of K; empty without supports): the springs of
  // the finite-strain solve (finite_strain.cpp).
  dealii::SparseMatrix<double> K_support;
  dealii::Vector<double> f_support;  // the load k w_p b_p of the supports' bases (a part of f)
  double assemble_seconds = 0.0;

  // ---- solvers (cached across solve() calls) -----------------------------------------------
  std::string
      method;  // "cholmod" | "cg+amg" | "mumps (mpi, N ranks)" | "cg+amg (mpi, N ranks)" once prepared
  std::string method_reason;  // over MPI ranks: why `method`
  std::string prepared_for;   // the solver choice `method` was prepared for (prepare_solver)
  std::unique_ptr<CholmodLLT> direct;
  std::unique_ptr<dealii::TrilinosWrappers::SparseMatrix> K_trilinos;
  std::unique_ptr<dealii::TrilinosWrappers::PreconditionAMG> amg;
  // distribute_solves(): K⁻¹ over the ranks of solve_comm (MPI_COMM_NULL: serial)
  MPI_Comm solve_comm = MPI_COMM_NULL;
  std::unique_ptr<DistributedInverse<dim>> distributed;
  // The cells (material ids) the calling rank owned in the last distributed triangulation built for
  // this model, ascending, and the number of ranks it was built for (0: none yet).
  mutable std::vector<std::size_t> owned_cells;
  mutable unsigned owned_cells_ranks = 0;
  double prepare_seconds = 0.0;
  bool have_u0 = false;
  dealii::Vector<double> u0;  // K⁻¹ f
  unsigned u0_iterations = 0;
  ColumnCache columns;

  // ---- last solution -----------------------------------------------------------------------
  bool have_solution = false;
  dealii::Vector<double> u;
  // A voxel model's last solve_distributed through solve() (no serial mesh): its vertex displacement,
  // which sample() interpolates multilinearly on the grid (= the Q1 field); empty otherwise.
  std::vector<Vec<dim>> grid_vertex_u;

  // ---- set-up, conditions and assembly (model.cpp) -------------------------------------------
  // The serial triangulation of the (positively oriented) input simplices, material id = input index.
  void build_simplex_triangulation();
  // The serial voxel grid, material id = voxel index (its vertex numbering checked against `vertices`).
  void build_voxel_triangulation();
  // Builds the serial triangulation if not built yet, and the DoFs (every serial entry point; never
  // while the solves run over ranks).
  void ensure_mesh();
  // Forgets the assembled system and the solver state (a condition was added).
  void invalidate();
  // Index of the voxel containing x (clamped to the grid), axis 0 fastest.
  std::size_t voxel_index(const dealii::Point<dim>& x) const;
  // The Dirichlet conditions at one support point x whose DoFs, by component, are `dofs` (first
  // condition wins per DoF; see DirichletBC::axes): adds their lines to `constraints`, calls
  // hold(dof, b) for every DoF condition b holds, and appends the constrained directions at x to
  // `constrained` if it is given.
  void constrain_point(const dealii::Point<dim>& x,
                       const std::array<dealii::types::global_dof_index, dim>& dofs,
                       dealii::AffineConstraints<double>& constraints,
                       const std::function<void(dealii::types::global_dof_index, int)>& hold,
                       ConstrainedDirections<dim>* constrained) const;
  // Local stiffness and load of one cell (fe_values/fe_face_values reinit'ed inside).
  void local_system(const Cell& cell, dealii::FEValues<dim>& fe_values,
                    dealii::FEFaceValues<dim>& fe_face_values, dealii::FullMatrix<double>& Ke,
                    dealii::Vector<double>& fe_rhs) const;
  std::unique_ptr<dealii::FEValues<dim>> make_fe_values() const;
  std::unique_ptr<dealii::FEFaceValues<dim>> make_face_values() const;
  // The serial system: support points, Dirichlet constraints and assemble_matrices() (once per set of
  // conditions). Not used while the solves run over ranks (each rank then assembles its part of the
  // distributed system).
  void assemble();
  // K, K_full, f, f_full and the volume supports (once per set of conditions).
  void assemble_matrices();
  // distribute_solves() over more than one rank: the solves then run on the distributed system alone,
  // in its DoF numbering (u0, u and the cached columns), and the serial mesh is never built.
  bool solves_over_ranks() const;
  // The DoFs of the solves: the distributed system's, or the serial DoFHandler's.
  dealii::types::global_dof_index n_solve_dofs() const;
  // The stencils of `points` in the numbering of the solves (collective when they run over ranks).
  std::vector<PointStencil> stencils(const std::vector<Vec<dim>>& points) const;
  // The same for points x_i in given cells c_i (input cell / voxel index; −1: outside).
  std::vector<PointStencil> stencils_in(const std::vector<std::pair<long, dealii::Point<dim>>>& at) const;
  // The last solution u at such points (std::nullopt outside); collective when the solves run over ranks.
  std::vector<std::optional<Vec<dim>>> values_in(
      const std::vector<std::pair<long, dealii::Point<dim>>>& at) const;
  // Sets the Dirichlet-constrained entries of a solution from its free ones.
  void distribute_constraints(dealii::Vector<double>& x) const;

  // ---- solvers (solvers.cpp) -----------------------------------------------------------------
  // Assembles, then factorises K (UMFPACK) or sets up AMG, as `opt` and the size ask (once per method).
  void prepare_solver(const SolverOptions& opt);
  // x = K⁻¹ b with the prepared solver; returns CG iterations (0 for the direct solver).
  unsigned apply_inverse(const dealii::Vector<double>& b, dealii::Vector<double>& x, const SolverOptions& opt,
                         double* residual = nullptr) const;
  // Computes u0 = K⁻¹f once per prepared solver (its CG iterations are kept in u0_iterations).
  void ensure_u0(const SolverOptions& opt, double* residual = nullptr);

  // ---- post-processing and point location (postprocess.cpp) ---------------------------------
  const CellLocator<dim>& cell_locator() const;
  // Fills cell_of_index from the serial triangulation (once).
  void serial_cells() const;
  // The cell containing x and x's reference coordinates, or (tria.end(), ·) if x is outside the mesh.
  Located locate(const dealii::Point<dim>& x) const;
  // Vertex displacement, centroid strain/stress, energy and reactions of u: over the ranks when K⁻¹
  // runs over them (DistributedInverse::fields), else postprocess_serial.
  Solution<dim> postprocess();
  // The same from the serial K_full, f_full and the post-processing cache.
  void postprocess_serial(Solution<dim>& s);
  // Strain at the centroid of `cell` from the local DoF values.
  Eigen::Matrix<double, dim, dim> centroid_strain(const Cell& cell, dealii::FEValues<dim>& centroid_values,
                                                  const std::vector<double>& local_u) const;
  void stress_of(const Eigen::Matrix<double, dim, dim>& eps, double E_cell,
                 Eigen::Matrix<double, dim, dim>& sigma, double& von_mises) const;

 private:
  void local_voxel(const Cell& cell, dealii::FEValues<dim>& fv, const Lame<double>& law,
                   dealii::FullMatrix<double>& Ke, dealii::Vector<double>& Fe) const;
  void local_p1(const Cell& cell, const Lame<double>& law, dealii::FullMatrix<double>& Ke,
                dealii::Vector<double>& Fe) const;
  void local_quadrature(const Cell& cell, dealii::FEValues<dim>& fv, const Lame<double>& law,
                        dealii::FullMatrix<double>& Ke, dealii::Vector<double>& Fe) const;
  void add_surface_loads(const Cell& cell, dealii::FEFaceValues<dim>& ffv, dealii::Vector<double>& Fe) const;
  void find_support_points_and_components();
  ConstrainedDirections<dim> apply_dirichlet_conditions();
  void assemble_cells();
  void assemble_supports();
  void build_post_cache();

 public:
  // f_support from the supports' bases (solvers.cpp), replacing the previous one in f.
  void assemble_support_load();
};

// The model's state, for the functions outside ElasticModel that need it (solve_distributed).
struct ModelAccess {
  template <int dim>
  using State = typename ElasticModel<dim>::Impl;
  template <int dim>
  static State<dim>& state(ElasticModel<dim>& model) {
    return *model.impl_;
  }
  template <int dim>
  static const State<dim>& state(const ElasticModel<dim>& model) {
    return *model.impl_;
  }
};

// CHOLMOD's factor of a symmetric positive definite sparse matrix (solvers.cpp); std::runtime_error
// if it is not positive definite.
std::unique_ptr<CholmodLLT> cholmod_factor(const dealii::SparseMatrix<double>& K);

// Initialises MPI (threads serialised) unless it is, and finalises it at exit then; throws
// std::runtime_error if MPI_Init_thread fails (solvers.cpp).
void ensure_mpi_initialized();

// The distributed K⁻¹ of a serially assembled model (distributed.cpp): the model's mesh partitioned
// over `comm` like solve_distributed, factorised once by MUMPS or CG + AMG with the rigid-body modes, as
// `opt` chooses (SolverOptions::max_memory). Collective.
template <int dim>
std::unique_ptr<DistributedInverse<dim>> make_distributed_inverse(const ModelAccess::State<dim>& model,
                                                                  MPI_Comm comm, const SolverOptions& opt);

}  // namespace vim::fem

// Internal to vim_fem (deal.II inside): the state behind ElasticModel<dim>, shared by the serial
// TU (elasticity.cpp) and the MPI TU (elasticity_mpi.cpp). Weak form (step-8):
//   ∫ λ (∇·u)(∇·v) + 2μ ε(u):ε(v) dx = ∫ b·v dx + ∫_Γ (t − p n)·v ds,   λ, μ per cell from (E_j, ν).
#pragma once

#include <vim/fem/elasticity.hpp>

#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/grid_tools_cache.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <suitesparse/umfpack.h>

#include <Epetra_MultiVector.h>
#include <Teuchos_ParameterList.hpp>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <tuple>
#include <vector>

namespace vim::fem {

// One scalar constraint row c·u = g on the free DoFs (Dirichlet DoFs condensed into g).
struct ConstraintRow {
  std::vector<dealii::types::global_dof_index> dofs;
  std::vector<double> values;
  std::vector<dealii::types::global_dof_index> dirichlet_dofs;  // the part moved to g (for reactions)
  std::vector<double> dirichlet_values;
  double g = 0.0;      // right-hand side after moving Dirichlet contributions over
  bool active = true;  // false: the point sits on Dirichlet DoFs only (the row is void)
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

// UMFPACK LU of the symmetric K, factorised once; solves without iterative refinement and with
// preallocated workspace (deal.II's SparseDirectUMFPACK refines twice per solve and solves the
// transposed system, about 3× the work per back-substitution the needle fast path needs).
class UmfpackLU {
 public:
  explicit UmfpackLU(const dealii::SparseMatrix<double>& K);
  ~UmfpackLU();
  UmfpackLU(const UmfpackLU&) = delete;
  UmfpackLU& operator=(const UmfpackLU&) = delete;
  void solve(dealii::Vector<double>& x) const;  // in place: x ← K⁻¹ x

 private:
  std::vector<SuiteSparse_long> Ap, Ai;
  std::vector<double> Ax;
  void* symbolic = nullptr;
  void* numeric = nullptr;
  double control[UMFPACK_CONTROL];
  mutable std::vector<SuiteSparse_long> Wi;
  mutable std::vector<double> W, b;
};

template <int dim>
struct ElasticModel<dim>::Impl {
  using Key = std::pair<std::array<double, dim>, std::array<double, dim>>;  // (position, direction) of a constraint row

  // ---- input -------------------------------------------------------------------------------
  bool voxel = false;
  // Voxel models: the grid (cells per axis, box). Their serial triangulation/DoFHandler is built on
  // first serial use (ensure_mesh); solve_distributed builds its own distributed grid instead, so an
  // MPI voxel solve never holds the whole mesh on a rank.
  std::array<long, dim> grid_cells{};
  dealii::Point<dim> grid_min, grid_max;
  bool mesh_built = false;
  bool dofs_ready = false;  // dof and cache set up (setup_dofs); simplex models too only on first serial use
  // Voxel cells are congruent boxes: K_e = λ_e Kλ + μ_e Kμ and ∫N_i from the first cell assembled.
  mutable bool voxel_reference_ready = false;
  mutable dealii::FullMatrix<double> voxel_K_lambda, voxel_K_mu;
  mutable std::vector<double> voxel_shape_integral;
  std::vector<Vec<dim>> vertices;
  std::vector<double> E;  // per input cell (material_id of a deal.II cell = its input index)
  double nu = 0.3;
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
  std::unique_ptr<dealii::GridTools::Cache<dim>> cache;

  // ---- assembled system (serial) -----------------------------------------------------------
  bool assembled = false;
  std::vector<dealii::Point<dim>> support_points;  // per DoF
  std::vector<int> dof_bc;                          // per DoF: owning DirichletBC or -1
  std::vector<unsigned> dof_component;              // per DoF: vector component
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
  double assemble_seconds = 0.0;

  // ---- solvers (cached across solve() calls) -----------------------------------------------
  std::string method;  // "umfpack" | "cg+amg" once prepared
  std::unique_ptr<UmfpackLU> direct;
  std::unique_ptr<dealii::TrilinosWrappers::SparseMatrix> K_trilinos;
  std::unique_ptr<dealii::TrilinosWrappers::PreconditionAMG> amg;
  double prepare_seconds = 0.0;
  bool have_u0 = false;
  dealii::Vector<double> u0;  // K⁻¹ f
  unsigned u0_iterations = 0;
  std::map<Key, std::pair<ConstraintRow, dealii::Vector<double>>> columns;  // row and K⁻¹cᵀ

  // ---- last solution -----------------------------------------------------------------------
  bool have_solution = false;
  dealii::Vector<double> u;

  // ---- shared helpers (elasticity.cpp) -----------------------------------------------------
  void setup_dofs();
  // Builds the serial voxel triangulation if not built yet, and the DoFs (every serial entry point).
  void ensure_mesh();
  // Index of the voxel containing x (clamped to the grid), axis 0 fastest.
  std::size_t voxel_index(const dealii::Point<dim>& x) const;
  // Per-DoF support points over the cells given by `cells` (all active cells in serial).
  // The Dirichlet conditions at one support point x whose DoFs, by component, are `dofs` (first
  // condition wins per DoF; see DirichletBC::axes): adds their lines to `constraints`, calls
  // hold(dof, b) for every DoF condition b holds, and appends the constrained directions at x to
  // `constrained` if it is given.
  void constrain_point(const dealii::Point<dim>& x, const std::array<dealii::types::global_dof_index, dim>& dofs,
                       dealii::AffineConstraints<double>& constraints,
                       const std::function<void(dealii::types::global_dof_index, int)>& hold,
                       std::vector<std::pair<dealii::Point<dim>, dealii::Tensor<1, dim>>>* constrained) const;
  // Throws unless the constrained directions (point, unit direction; this rank's share, summed over
  // `comm`) remove every rigid motion.
  void check_rigid_modes_removed(const std::vector<std::pair<dealii::Point<dim>, dealii::Tensor<1, dim>>>& constrained,
                                 MPI_Comm comm = MPI_COMM_SELF) const;
  // Local stiffness and load of one cell (fe_values/fe_face_values reinit'ed inside).
  void local_system(const typename dealii::DoFHandler<dim>::active_cell_iterator& cell,
                    dealii::FEValues<dim>& fe_values, dealii::FEFaceValues<dim>& fe_face_values,
                    dealii::FullMatrix<double>& Ke, dealii::Vector<double>& fe_rhs) const;
  std::unique_ptr<dealii::FEValues<dim>> make_fe_values() const;
  std::unique_ptr<dealii::FEFaceValues<dim>> make_face_values() const;
  // Strain at the centroid of `cell` from the local DoF values.
  Eigen::Matrix<double, dim, dim> centroid_strain(const typename dealii::DoFHandler<dim>::active_cell_iterator& cell,
                                                  dealii::FEValues<dim>& centroid_values,
                                                  const std::vector<double>& local_u) const;
  void stress_of(const Eigen::Matrix<double, dim, dim>& eps, double E_cell, Eigen::Matrix<double, dim, dim>& sigma,
                 double& von_mises) const;
};

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

// CG preconditioner for elasticity (serial and MPI solves): ML AMG with the rigid-body modes at
// the DoF support points (local index -> point, component) as a pre-computed null space.
// Linear elements (P1 simplices, Q1 voxel hexahedra): unsmoothed aggregation (damping factor 0),
// aggregation threshold 0, W-cycle; Chebyshev degree 1 on voxel grids (81 nonzeros per row), 2 on
// simplices. Voxel 50³ grid (398k DoFs, 2 ranks): smoothed aggregation (threshold 0.02, degree 2)
// took 37 CG iterations but a ~2.5x longer set-up and 1.43x the peak memory (1.05 vs 0.73 GB per
// rank; the 100³ grid ran out of memory with it); the unsmoothed hierarchy takes 66 iterations
// (V-cycle) / 53 (W-cycle) and is faster overall. P1 Kuhn 68³ (985k DoFs, 2 ranks): smoothed
// aggregation (threshold 0.02) set-up 10.8 s + CG 7.6 s (62 iterations), threshold 0 13.0 + 5.0 s
// (38), unsmoothed V-cycle 2.5 + 9.1 s (102), unsmoothed W-cycle 2.7 + 6.4 s (62), with 18 % less
// peak memory (docs/performance.md, issue 5). P2 keeps smoothed aggregation (threshold 0.02,
// degree 2, V-cycle), not re-measured.
template <int dim>
inline void amg_setup(const dealii::TrilinosWrappers::SparseMatrix& K, const std::function<dealii::Point<dim>(unsigned)>& support_of_local,
               const std::function<unsigned(unsigned)>& component_of_local, unsigned degree, bool voxel_grid,
               dealii::TrilinosWrappers::PreconditionAMG& amg) {
  const bool unsmoothed = degree == 1;
  constexpr int nm = dim == 2 ? 3 : 6;
  dealii::TrilinosWrappers::PreconditionAMG::AdditionalData data;
  data.elliptic = true;
  data.higher_order_elements = degree > 1;
  data.smoother_sweeps = voxel_grid ? 1 : 2;
  data.aggregation_threshold = unsmoothed ? 0.0 : 0.02;
  data.w_cycle = unsmoothed;
  Teuchos::ParameterList pl;
  std::unique_ptr<Epetra_MultiVector> unused;
  data.set_parameters(pl, unused, K);
  if (unsmoothed) pl.set("aggregation: damping factor", 0.0);
  Epetra_MultiVector nsp(K.trilinos_matrix().DomainMap(), nm);
  const int n_local = K.trilinos_matrix().DomainMap().NumMyElements();
  for (int i = 0; i < n_local; ++i) {
    const dealii::Point<dim> x = support_of_local(static_cast<unsigned>(i));
    const unsigned c = component_of_local(static_cast<unsigned>(i));
    for (int k = 0; k < nm; ++k) nsp[k][i] = 0.0;
    nsp[c][i] = 1.0;
    if constexpr (dim == 2) {
      nsp[2][i] = c == 0 ? -x[1] : x[0];
    } else {
      const double rot[3][3] = {{0.0, x[2], -x[1]}, {-x[2], 0.0, x[0]}, {x[1], -x[0], 0.0}};
      for (int a = 0; a < 3; ++a) nsp[3 + a][i] = rot[a][c];
    }
  }
  pl.set("null space: type", "pre-computed");
  pl.set("null space: dimension", nm);
  pl.set("null space: vectors", nsp.Values());
  pl.set("null space: add default vectors", false);
  pl.set("PDE equations", dim);
  amg.initialize(K, pl);
}

}  // namespace vim::fem

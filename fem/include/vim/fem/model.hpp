// Small-strain linear elasticity on simplex meshes (P1/P2) and on voxel hexahedra (Q1), with a
// per-cell Young's modulus and constant Poisson ratio (paper §VI-C; docs/architecture.md, fem module):
// the model, its solver options and statistics, and the solution it returns.
// This header is deal.II-free: plain Eigen/std arrays in and out; deal.II lives in fem/src.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/fem/cell_locator.hpp>
#include <vim/fem/conditions.hpp>
#include <vim/fem/point_constraints.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim::fem {

// The Dirichlet conditions and volume supports leave a rigid-body motion free: the stiffness matrix is
// singular. Thrown by the first solve; a distinct type so that callers can name their own input.
struct SingularConstraints : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SolverOptions {
  enum class Type { automatic, direct, amg } type = Type::automatic;
  double tolerance = 1e-10;  // relative residual for CG
  unsigned max_iterations = 10000;
  // `automatic` uses the direct solver (CHOLMOD's sparse Cholesky) up to this many DoFs; 0 = the default
  // for the dimension, default_direct_limit(dim). 3D direct solves fill in, but CHOLMOD's factorisation
  // stays cheaper than one AMG solve up to ~120k DoFs (docs/performance.md), and on the AMG path each
  // new point constraint costs one CG solve instead of one back-substitution.
  unsigned direct_limit = 0;
  static constexpr unsigned default_direct_limit(int dim) { return dim == 2 ? 200000u : 150000u; }
  unsigned direct_limit_for(int dim) const { return direct_limit ? direct_limit : default_direct_limit(dim); }
  // Solves over MPI ranks (distribute_solves): the bytes a rank may give MUMPS's distributed
  // factorisation, compared with MUMPS's own estimate after its analysis (INFOG(16), the largest over
  // the ranks). `automatic` factorises simplex models with MUMPS when the estimate fits and uses CG + AMG
  // otherwise; `direct` refuses a model whose estimate exceeds it. 0 = no limit.
  double max_memory = 0.0;
};

struct SolverStats {
  std::string method;  // "cholmod" | "cg+amg" (solve), "umfpack-monolithic" (solve_monolithic)
  std::string reason;  // solves over MPI ranks: why `method` was chosen (the MUMPS estimate and limit)
  unsigned iterations = 0;
  double residual = 0.0;
  unsigned n_dofs = 0;
  double assemble_seconds = 0.0, solve_seconds = 0.0;
  // Parts of the above: setup_seconds of assemble_seconds (solve_distributed: distributed mesh, DoFs
  // and constraints; 0 in serial), precondition_seconds of solve_seconds (UMFPACK factorisation or
  // AMG set-up, counted by the solve that did it).
  double setup_seconds = 0.0, precondition_seconds = 0.0;
  // Point-constraint rows (one per selected component): used, and dropped because they are linear
  // combinations of earlier rows (e.g. >2 collinear points in one P1 element) but consistent with them.
  unsigned constraint_rows = 0, dependent_rows_dropped = 0;
};

template <int dim>
struct Solution {
  std::vector<Vec<dim>> vertex_displacement;                 // per mesh vertex (input numbering)
  std::vector<Eigen::Matrix<double, dim, dim>> cell_strain;  // per cell, at the centroid
  std::vector<Eigen::Matrix<double, dim, dim>> cell_stress;
  std::vector<double> von_mises;             // per cell
  double strain_energy = 0.0;                // ½ uᵀ K u
  std::vector<Vec<dim>> dirichlet_reaction;  // per DirichletBC: Σ (K u − f) over its constrained DoFs
  // Per PointConstraint: the force the constraint applies ON THE BODY at that point, in the model's
  // axes (Σ_c −μ_c axes.col(c) over the selected components; with K u = f − Cᵀμ a point pulled in +x
  // gets a force with +x sign).
  std::vector<Vec<dim>> point_force;
  SolverStats stats;
};

struct PointSample {
  std::vector<bool> inside;  // false: point outside the mesh (value left at zero)
  std::size_t n_outside = 0;
};

struct ModelAccess;  // fem/src: gives solve_distributed (vim/fem/distributed.hpp) the model's state

// The problem. Construct, add conditions, then solve(); the stiffness matrix is assembled and
// (for the direct solver) factorised once and reused by later solves with other point constraints.
template <int dim>
class ElasticModel {
 public:
  // Simplex model: per-cell Young's modulus (one per mesh cell), constant ν, FE_SimplexP(degree).
  ElasticModel(const SimplexMesh<dim>& mesh, std::vector<double> youngs_modulus, double poisson_ratio,
               unsigned degree = 1);
  // Voxel reference model: a structured grid of cells[0]×…×cells[dim-1] Q1 hexahedra (quads in 2D)
  // spanning [box_min, box_max]; moduli in the same order as Image data (axis 0 fastest).
  static ElasticModel voxel_grid(const std::array<long, dim>& cells, const Vec<dim>& box_min,
                                 const Vec<dim>& box_max, std::vector<double> youngs_modulus,
                                 double poisson_ratio);
  ~ElasticModel();
  ElasticModel(ElasticModel&&) noexcept;
  ElasticModel& operator=(ElasticModel&&) noexcept;

  void add_dirichlet(const DirichletBC<dim>& bc);
  void add_surface_load(const SurfaceLoad<dim>& load);
  void set_body_force(const Vec<dim>& f);
  // Elastic support over sample points (see VolumeSupport); throws std::invalid_argument for
  // k ≤ 0 or not finite, sizes that differ, negative or non-finite weights or points.
  void add_volume_support(const VolumeSupport<dim>& support);
  // Moves the base of volume support `index` (in the order added) to `base` (one displacement per
  // point; empty: at rest): a change of the load k w_p b_p only, so K's factorisation and the cached
  // columns K⁻¹cᵀ are kept and the next solve does one back-substitution for K⁻¹f. Serial solves only;
  // throws std::invalid_argument for an index out of range, a size that differs or values not finite.
  void set_volume_support_base(std::size_t index, std::vector<Vec<dim>> base);
  // Sample points of the volume supports that lie outside the mesh (known after the first assembly).
  std::size_t volume_support_points_outside() const;

  unsigned n_dofs() const;
  unsigned n_cells() const;
  // Vertices of the model (input mesh vertices, or grid vertices for voxel_grid).
  const std::vector<Vec<dim>>& vertices() const;
  // The point locator of the model's cells (input cell order; voxel models: the grid, axis 0 fastest),
  // built on first use. It locates the point constraints, the sample points and the volume supports.
  const CellLocator<dim>& locator() const;

  // Solve with the given embedded point constraints (may be empty). Throws std::runtime_error
  // if no Dirichlet condition removes the rigid-body modes. A constraint row that depends linearly on
  // earlier rows (P1 is affine in an element, so three collinear points in one element are redundant)
  // is dropped if the solution satisfies it anyway (its force is then carried by the earlier rows),
  // otherwise std::runtime_error names it as conflicting. A point outside the mesh, or on Dirichlet
  // nodes with a different value → std::invalid_argument. Rows and columns K⁻¹cᵀ are cached by
  // (position, component) until a condition is added.
  Solution<dim> solve(const std::vector<PointConstraint<dim>>& points = {},
                      const SolverOptions& options = {});
  // Computes and caches the rows and columns K⁻¹cᵀ of every selected component of `points` (their
  // displacements and compliances do not matter) in one batch — blocks of right-hand sides through the
  // Cholesky factor, or one CG solve per row on the AMG path — and their products c_a·K⁻¹c_bᵀ, after
  // factorising K if needed: later solve() calls whose rows are all cached do no sparse solve, only
  // dense work on the rows. Returns the number of rows computed (not cached before). Same errors as
  // solve() for points outside the mesh or bad values.
  unsigned precompute(const std::vector<PointConstraint<dim>>& points, const SolverOptions& options = {});
  // The same, as one monolithic saddle-point solve [K Cᵀ; C 0] (reference for the fast path).
  Solution<dim> solve_monolithic(const std::vector<PointConstraint<dim>>& points,
                                 const SolverOptions& options = {});

  // Displacement of the last solution at arbitrary points (located with locator()).
  std::vector<Vec<dim>> sample(const std::vector<Vec<dim>>& points, PointSample* info = nullptr) const;

  // Displacement of the last solution at the midpoint of each edge, given as a pair of vertex indices
  // (input numbering) of an edge of the simplex mesh: for P2 the values of the edge's mid-node DoFs
  // (P2 support points), for P1 the mean of the two vertex values. Together with
  // Solution::vertex_displacement this is the whole P2 field (quadratic cells for VTK, C3D10/CPE6
  // nodes). Simplex models only; throws std::invalid_argument for a pair that is no edge of the mesh
  // and std::runtime_error before the first solve.
  std::vector<Vec<dim>> edge_midpoint_displacement(const std::vector<std::array<int, 2>>& edges) const;

  // ½ uᵀ K u for the continuous piecewise-linear field with the given vertex values (interpolated
  // into the FE space; exact for P1/Q1, and for P2 a linear-per-cell field is represented exactly).
  double strain_energy_of(const std::vector<Vec<dim>>& vertex_displacement) const;

  // Bytes held by the model's deal.II objects on the calling process: mesh, DoFs, constraints,
  // assembled matrices and vectors, cached solution and compliance columns, and its part of the
  // distributed system with the AMG preconditioner when the solves run over ranks (not CHOLMOD's
  // factor).
  std::size_t memory_consumption() const;
  // The deal.II cells the calling process holds for the model: its serial mesh (built on first serial
  // use) plus, when the solves run over ranks, its owned and ghost cells of the distributed mesh.
  std::size_t cells_held() const;

  // Per-cell Young's modulus as used (input cell order) and the Poisson ratio.
  const std::vector<double>& youngs_modulus() const;
  double poisson_ratio() const;
  unsigned degree() const;

 private:
  ElasticModel();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend struct ModelAccess;
};

}  // namespace vim::fem

// Small-strain linear elasticity on simplex meshes (P1/P2) and on voxel hexahedra (Q1), with a
// per-cell Young's modulus and constant Poisson ratio (paper §VI-C, DESIGN.md §4).
// This header is deal.II-free: plain Eigen/std arrays in and out; deal.II lives in fem/src.
#pragma once

#include <vim/simplex_mesh.hpp>

#include <Eigen/Core>
#include <mpi.h>

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <stdexcept>
#include <vector>

namespace vim::fem {

template <int dim>
using Vec = Eigen::Matrix<double, dim, 1>;

// A geometric selector in the model's coordinates. A node (support point) belongs to the region
// when contains(x) is true; a boundary face belongs when all its vertices do.
template <int dim>
struct Region {
  std::string name;
  std::function<bool(const Vec<dim>&)> contains;
};

// Region helpers (tolerance `tol` in length units).
template <int dim> Region<dim> box_face_region(const Vec<dim>& box_min, const Vec<dim>& box_max, int axis, bool upper, double tol);
template <int dim> Region<dim> sphere_region(const Vec<dim>& center, double radius);
template <int dim> Region<dim> box_region(const Vec<dim>& lo, const Vec<dim>& hi);
template <int dim> Region<dim> cylinder_region(const Vec<dim>& center, const Vec<dim>& axis, double radius);  // infinite cylinder (2D: slab)

// u_c = value_c on every support point in region, for each component c with components[c] true.
// If `function` is set it replaces `value`: u_c = function(x)_c (e.g. a linear field for patch tests).
// A DoF selected by several conditions takes the FIRST condition added (and counts for its reaction).
// `axes` (orthonormal columns; identity = the model's axes) turns the components into directions:
// axes.col(c)·u = value_c for each selected c, e.g. a support that slides along a face that is not
// normal to a model axis. A condition with other axes holds a support point only if no earlier
// condition holds any of its DoFs, and then holds all of them (its reaction sums all of them).
template <int dim>
struct DirichletBC {
  Region<dim> region;
  std::array<bool, dim> components = filled(true);
  Vec<dim> value = Vec<dim>::Zero();
  std::function<Vec<dim>(const Vec<dim>&)> function = {};
  Eigen::Matrix<double, dim, dim> axes = Eigen::Matrix<double, dim, dim>::Identity();
  static std::array<bool, dim> filled(bool b) { std::array<bool, dim> a; a.fill(b); return a; }
};

// Surface load on boundary faces inside `region`: traction vector t, plus pressure p along the
// inward normal (t_total = t - p·n, n the outward normal).
template <int dim>
struct SurfaceLoad {
  Region<dim> region;
  Vec<dim> traction = Vec<dim>::Zero();
  double pressure = 0.0;
};

// Elastic support (a Winkler foundation) inside a volume: adds the energy ½ k Σ_p w_p |u(x_p)|², a
// quadrature of ½ ∫_R k |u|² dx over the sample points x_p (weights w_p in volume units), to the
// stiffness. Unlike a DirichletBC, which holds the nodes that happen to lie in a region, it does not
// depend on where the mesh puts its nodes: the same points, weights and k give every mesh (simplex or
// voxel) the same support, and a region that holds no node still holds the tissue. As k → ∞ the
// support tends to u = 0 on every cell that holds a sample point. Points outside the mesh are ignored
// (counted in n_outside after the first solve). Serial solves only (not solve_distributed).
template <int dim>
struct VolumeSupport {
  std::string name;
  std::vector<Vec<dim>> points;
  std::vector<double> weights;  // one per point (volume each point stands for)
  double stiffness = 0.0;       // k > 0: force per length^(dim+1) (modulus per length²)
};

// u(position) = displacement (selected components), for a point anywhere inside the mesh:
// a linear constraint on the DoFs of the cell containing it, through its shape functions.
// `axes` (orthonormal columns; identity = the model's axes) makes component c the direction
// axes.col(c): axes.col(c)·u(position) = displacement_c. With every component selected the axes
// change nothing but which rows a degenerate set drops: a point on nodes that a DirichletBC holds
// along its own axes leaves those directions to the condition when it uses the same axes.
template <int dim>
struct PointConstraint {
  Vec<dim> position;
  Vec<dim> displacement = Vec<dim>::Zero();
  std::array<bool, dim> components = DirichletBC<dim>::filled(true);
  Eigen::Matrix<double, dim, dim> axes = Eigen::Matrix<double, dim, dim>::Identity();
};

// Eq. 15: E_j = clamp(scale · mean_j, min, max) per element, from the per-element voxel means
// (the mesher's ElementValue::mean). Throws std::invalid_argument naming the element index and value
// for NaN/inf means, or a result that is not > 0 (a negative mean is fine if the clamp lifts it);
// also for scale not finite/> 0 and a clamp with min <= 0 or min > max.
std::vector<double> element_modulus(const std::vector<double>& element_mean, double scale = 1.0,
                                    std::optional<std::pair<double, double>> clamp = std::nullopt);

// Block means of a voxel image (axis 0 fastest) over factor^dim blocks, for a downsampled fine voxel
// reference; dims must be divisible by factor. Returns the coarse values; `coarse_dims` gets the size.
template <int dim>
std::vector<double> block_mean(const std::array<long, dim>& dims, const std::vector<double>& values, int factor,
                               std::array<long, dim>* coarse_dims = nullptr);

// Lamé parameters from (E, ν): {λ, μ}. 2D is plane strain everywhere in this module.
std::pair<double, double> lame_parameters(double youngs_modulus, double poisson_ratio);

// The Dirichlet conditions and volume supports leave a rigid-body motion free: the stiffness matrix is
// singular. Thrown by the first solve; a distinct type so that callers can name their own input.
struct SingularConstraints : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Point constraints (embedded needle points) that are linear combinations of earlier ones, numerically,
// but ask for other displacements: e.g. shaft points close together along an edge of the mesh.
struct DependentPointConstraints : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SolverOptions {
  enum class Type { automatic, direct, amg } type = Type::automatic;
  double tolerance = 1e-10;       // relative residual for CG
  unsigned max_iterations = 10000;
  // `automatic` uses UMFPACK up to this many DoFs; 0 = the default for the dimension,
  // default_direct_limit(dim). 3D direct solves fill in badly (P1, one factorisation: 32k DoFs 8.6 s,
  // 53k DoFs 26 s, 98k DoFs 123 s and 4.2 GB, against 0.9 / 1.5 / 6 s for CG+AMG; docs/performance.md).
  // On the AMG path each new point constraint costs one CG solve instead of one back-substitution.
  unsigned direct_limit = 0;
  static constexpr unsigned default_direct_limit(int dim) { return dim == 2 ? 200000u : 30000u; }
  unsigned direct_limit_for(int dim) const { return direct_limit ? direct_limit : default_direct_limit(dim); }
};

struct SolverStats {
  std::string method;           // "umfpack" | "cg+amg"
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
  std::vector<Vec<dim>> vertex_displacement;   // per mesh vertex (input numbering)
  std::vector<Eigen::Matrix<double, dim, dim>> cell_strain;  // per cell, at the centroid
  std::vector<Eigen::Matrix<double, dim, dim>> cell_stress;
  std::vector<double> von_mises;               // per cell
  double strain_energy = 0.0;                  // ½ uᵀ K u
  std::vector<Vec<dim>> dirichlet_reaction;    // per DirichletBC: Σ (K u − f) over its constrained DoFs
  // Per PointConstraint: the force the constraint applies ON THE BODY at that point, in the model's
  // axes (Σ_c −μ_c axes.col(c) over the selected components; with K u = f − Cᵀμ a point pulled in +x
  // gets a force with +x sign).
  std::vector<Vec<dim>> point_force;
  SolverStats stats;
};

struct PointSample {
  std::vector<bool> inside;      // false: point outside the mesh (value left at zero)
  std::size_t n_outside = 0;
};

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
  // Sample points of the volume supports that lie outside the mesh (known after the first assembly).
  std::size_t volume_support_points_outside() const;

  unsigned n_dofs() const;
  unsigned n_cells() const;
  // Vertices of the model (input mesh vertices, or grid vertices for voxel_grid).
  const std::vector<Vec<dim>>& vertices() const;

  // Solve with the given embedded point constraints (may be empty). Throws std::runtime_error
  // if no Dirichlet condition removes the rigid-body modes. A constraint row that depends linearly on
  // earlier rows (P1 is affine in an element, so three collinear points in one element are redundant)
  // is dropped if the solution satisfies it anyway (its force is then carried by the earlier rows),
  // otherwise std::runtime_error names it as conflicting. A point outside the mesh, or on Dirichlet
  // nodes with a different value → std::invalid_argument. Rows and columns K⁻¹cᵀ are cached by
  // (position, component) until a condition is added.
  Solution<dim> solve(const std::vector<PointConstraint<dim>>& points = {}, const SolverOptions& options = {});
  // The same, as one monolithic saddle-point solve [K Cᵀ; C 0] (reference for the fast path).
  Solution<dim> solve_monolithic(const std::vector<PointConstraint<dim>>& points, const SolverOptions& options = {});

  // Solve over `comm` with Trilinos CG + AMG with rigid-body modes: simplex models on a METIS-partitioned
  // parallel::shared::Triangulation (every rank holds the whole mesh); voxel models on a p4est
  // parallel::distributed::Triangulation built from the grid description, so a rank holds only its part
  // (a voxel model's serial mesh is built only if solve()/solve_monolithic()/strain_energy_of() is used).
  // Collective: every rank must hold the same model (same mesh, moduli, conditions) and call
  // it. Every rank gets the full vertex_displacement, per-cell fields, strain energy and reactions.
  // Point constraints are not supported here (use solve()). With more than one rank, OpenBLAS, OpenMP
  // and deal.II's TBB run one thread per rank during the call (their worker threads otherwise spin on
  // the cores the other ranks need); the previous limits are restored on return.
  Solution<dim> solve_distributed(MPI_Comm comm, const SolverOptions& options = {});

  // Displacement of the last solution at arbitrary points (compute_point_locations).
  std::vector<Vec<dim>> sample(const std::vector<Vec<dim>>& points, PointSample* info = nullptr) const;

  // Displacement of the last solution at the midpoint of each edge, given as a pair of vertex indices
  // (input numbering) of an edge of the simplex mesh: for P2 the values of the edge's mid-node DoFs
  // (P2 support points), for P1 the mean of the two vertex values. Together with
  // Solution::vertex_displacement this is the whole P2 field (quadratic cells for VTK, C3D10/CPE6
  // nodes). Simplex models only; throws std::invalid_argument for a pair that is no edge of the mesh
  // and std::runtime_error before the first solve. (fem/src/edge_midpoints.cpp)
  std::vector<Vec<dim>> edge_midpoint_displacement(const std::vector<std::array<int, 2>>& edges) const;

  // ½ uᵀ K u for the continuous piecewise-linear field with the given vertex values (interpolated
  // into the FE space; exact for P1/Q1, and for P2 a linear-per-cell field is represented exactly).
  double strain_energy_of(const std::vector<Vec<dim>>& vertex_displacement) const;

  // Per-cell Young's modulus as used (input cell order) and the Poisson ratio.
  const std::vector<double>& youngs_modulus() const;
  double poisson_ratio() const;
  unsigned degree() const;

 private:
  ElasticModel();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::fem

// State of the VIM optimisation (paper §IV): the mesh, per-element caches of the voxel sums and of
// E_G, E_D (Eq. 3, 6), the fixed normalisation of §IV-C, and the node/connectivity updates of
// §IV-B that lower E = (1−λ)·E_G/E_G0 + λ·E_D/E_D0 (Eq. 7) under the quality bound.
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>
#include <vim/adjacency.hpp>
#include <vim/image.hpp>
#include <vim/invariants.hpp>
#include <vim/label_statistics.hpp>
#include <vim/quality.hpp>
#include <vim/simplex_mesh.hpp>
#include <vim/vim.hpp>
#include <vim/voxel_statistics.hpp>

namespace vim {

// Per-element cache: voxel sums (n, S, Q shifted by VoxelStatistics::shift(); a one-voxel stand-in for a
// uniform element, see VoxelStatistics::varied_sums), volume, E_G (density weighted), E_D and the
// element's share of the normalised objective.
struct CellCache {
  long n = 0;
  double s = 0.0, q = 0.0;
  double volume = 0.0, eg = 0.0, ed = 0.0, cost = 0.0;
};

// Population variance from shifted sums; round-off of a constant set (below 1e-10 of the second
// moment) is snapped to exactly 0, so a constant image gives E_D0 = 0 and switches the term off.
inline double element_variance(long n, double s, double q) {
  if (n <= 0) return 0.0;
  const double m2 = q / static_cast<double>(n), mean = s / static_cast<double>(n);
  const double var = m2 - mean * mean;
  return var > 1e-10 * m2 ? var : 0.0;
}

struct EnergyTotals {
  double geometric = 0.0, discretization = 0.0, energy = 0.0;
};

template <int dim>
class VimOptimizer {
 public:
  using Point = Eigen::Matrix<double, dim, 1>;
  using Simplex = std::array<Point, dim + 1>;
  using Cell = std::array<int, dim + 1>;

  // stats == nullptr: geometry only (E_D ≡ 0). density != nullptr: E_G of each element is weighted by
  // the density sampled at its centroid (§VI-E sizing). The box constraints use the mesh's bounding
  // box: corners fixed, edge nodes slide along their edge, face nodes within their face.
  // Throws std::invalid_argument if a cell is inverted or degenerate (signed volume <= 0).
  // labels != nullptr: the image is a label image (stats must be &labels->values()) and E_D of an
  // element is |τ|·Σ_l var(1_l), the variance of every label's indicator summed (docs/labels.md).
  VimOptimizer(SimplexMesh<dim> mesh, const VoxelStatistics<dim>* stats, const Image<dim>* density,
               const VimOptions& options, const LabelStatistics<dim>* labels = nullptr);

  // Fixes E_G0, E_D0 from the current mesh (§IV-C) and recomputes every element's cost.
  // E_D0 == 0 (constant image, or no image) switches the image term off. If the mesh's E_D is 0 but the
  // image varies inside the box (the mesh fits it exactly), E_D0 is estimated instead (normalization.cpp).
  void fix_normalization();
  double eg0() const { return eg0_; }
  double ed0() const { return ed0_; }
  // True when E_D0 is the estimate of fix_normalization (the image varies but the mesh fits it exactly).
  bool ed0_estimated() const { return ed0_estimated_; }

  // One node-update sweep over the colour classes (parallel inside a class). Returns accepted moves,
  // writes Σ_i |Δx_i|² to *sum_sq, the number of nodes whose update ran to *searched and the number
  // of candidate positions evaluated to *evaluations.
  long update_nodes(int iteration, double* sum_sq, long* searched = nullptr, long* evaluations = nullptr);

  // One sequential pass of connectivity swaps (2D flips; 3D 2-3, 3-2, 4-4). Returns accepted swaps.
  long swap_pass();
  // Individual swaps (tests and swap_pass). Each is taken iff every new element is acceptable, the
  // new elements tile the same region, and E drops. Return true if taken.
  bool try_flip(int cell, int local_vertex);     // 2D: flip the edge opposite local_vertex
  bool try_swap_23(int cell, int local_vertex);  // 3D: the facet opposite local_vertex
  bool try_swap_32(int a, int b);                // 3D: interior edge with 3 cells
  bool try_swap_44(int a, int b);                // 3D: interior edge with 4 cells

  // Splits the longest edge of up to k highest-cost elements (all cells sharing the edge are
  // split). Only splits that keep every new element acceptable and do not raise E are taken.
  long insert_nodes(long k);

  // Checks the invariants of invariants.hpp (nodes in the box and on their faces, no inverted cell,
  // quality bound — its optional parts no stricter than the starting mesh —, conforming tiling of the box)
  // plus: the adjacency equals a rebuild from the cells, the per-element caches equal a fresh evaluation
  // (relative 1e-9) and E has not risen above previous_energy. Costs about one full evaluation of the mesh.
  // Throws InvariantViolation naming `stage`, `iteration` and the first violation.
  void check_invariants(const char* stage, int iteration, double previous_energy) const;

  // Sums over live cells (deterministic order, extended precision).
  EnergyTotals totals() const;
  // Brute-force recomputation of the totals from the mesh (check_invariants, tests).
  EnergyTotals recompute_totals() const;

  // Live cells in index order, positively oriented.
  SimplexMesh<dim> compact_mesh() const;

  const SimplexMesh<dim>& mesh() const { return mesh_; }
  const std::vector<char>& alive() const { return alive_; }
  const Adjacency<dim>& adjacency() const { return adj_; }
  double bbox_diagonal() const { return (box_max_ - box_min_).norm(); }
  const Point& box_min() const { return box_min_; }
  const Point& box_max() const { return box_max_; }
  // Recomputes the colour classes of the node graph (greedy, node order) after swaps or insertion.
  void recolour();

  // Evaluates one simplex (all cache fields; cost uses the current normalisation).
  CellCache evaluate(const Simplex& x) const;
  // The quality bound (vim::acceptable with the options' bounds, decided by QualityCheck).
  bool acceptable(const Simplex& x) const { return quality_(x, signed_volume<dim>(x)); }
  // Same, with x's signed volume already computed by the caller and optionally the precomputed face
  // opposite a moving vertex (bit-identical result).
  bool acceptable(const Simplex& x, double volume, const FixedFace<dim>* fixed = nullptr) const {
    return quality_(x, volume, fixed);
  }
  Simplex simplex(int cell) const { return cell_points(mesh_, static_cast<std::size_t>(cell)); }

 private:
  template <int>
  friend struct OptimizerTestAccess;  // tests/support/optimizer_access.hpp

  struct Scratch {
    std::vector<int> ring, local;
    std::vector<Simplex> base;
    std::vector<CellCache> trial, best;
    std::vector<Point> dirs, kept;
    struct Probe {
      double value, f1;  // lower probe value; exact value at the first probe point (or NaN)
      std::size_t direction;
    };
    std::vector<Probe> top;             // screening: the best directions so far
    std::vector<double> known_f1;       // per kept direction: Probe::f1
    std::vector<FixedFace<dim>> faces;  // per 1-ring element: the face opposite the node
    std::vector<int> order;             // 1-ring positions by decreasing current E_D (voxel sums first)
    std::vector<double> ed_cost;        // per 1-ring element: the candidate's weighted E_D term
    long evaluations = 0;               // candidates evaluated by the current node update
  };
  struct NodeSearch;  // one node's candidate search (node_update.cpp)
  double load_ring(int node, Scratch& s, bool* image) const;
  bool update_node_impl(int node, int iteration, Scratch& s, double* moved_sq);
  double evaluate_candidate(const Point& p, Scratch& s, double bound, bool image) const;
  double cost_of(const CellCache& c) const;
  // The variance E_D weighs for x with voxel sums s (of the grey values, or of the label values):
  // the grey-value variance, or with labels the indicator variance (0 where s holds one label).
  double data_variance(const Simplex& x, const typename VoxelStatistics<dim>::Sums& s) const;
  // Replaces the n_old cells old_cells[] by the best of n_alt alternatives that lowers E; alternative
  // a is the n_new vertex tuples alternatives[a·n_new ..]. Uses the swap_* scratch below, so that a
  // swap pass allocates nothing per candidate (only the adjacency's facet map, per accepted swap).
  bool try_replace(const int* old_cells, int n_old, const Cell* alternatives, int n_alt, int n_new);
  bool try_facet_swap(int cell, int local_vertex);  // try_flip (2D) and try_swap_23 (3D)
  bool try_ring_swap(int a, int b, std::size_t m);  // try_swap_32 (m = 3) and try_swap_44 (m = 4)
  std::vector<Cell> swap_cells_, swap_best_cells_;
  std::vector<CellCache> swap_caches_, swap_best_caches_;
  std::vector<Simplex> swap_simplices_;
  std::vector<int> swap_slots_, swap_ring_, swap_cycle_;
  void set_cell(int c, const Cell& v, const CellCache& cache);
  int new_cell_slot();
  std::uint8_t classify(const Point& p) const;

  SimplexMesh<dim> mesh_;
  std::vector<char> alive_;
  std::vector<int> free_;
  std::size_t n_live_ = 0;
  bool ed0_estimated_ = false;
  std::vector<CellCache> cache_;
  std::vector<std::uint8_t> fixed_;  // bit a set: coordinate a is fixed (node on an axis-a face)
  Adjacency<dim> adj_;
  std::vector<std::vector<int>> colours_;
  // Per node: its 1-ring changed since its last (unsuccessful) line search. A clean node would
  // repeat exactly the same search, so update_nodes skips it (line-search strategy only).
  std::vector<char> dirty_;
  void mark_ring_dirty(int node);

  const VoxelStatistics<dim>* stats_;
  const LabelStatistics<dim>* labels_;
  const Image<dim>* density_;
  VimOptions options_;
  QualityCheck<dim> quality_;
  // The bound check_invariants holds the mesh to: the options' bound, its optional minimum angle and
  // radius ratio relaxed to the starting mesh's worst cells (a cell that starts below them is kept
  // unless a move improves it; the maximum angle stays strict).
  QualityBound invariant_bound_;
  Point box_min_, box_max_;
  double boundary_tol_ = 0.0;
  double min_step_ = 0.0;  // line-search stopping step (physical)
  double eg0_ = 1.0, ed0_ = 0.0;
  double wg_ = 1.0, wd_ = 0.0;  // cost = wg·E_G + wd·E_D
  mutable tbb::enumerable_thread_specific<Scratch> scratch_;
};

extern template class VimOptimizer<2>;
extern template class VimOptimizer<3>;

}  // namespace vim

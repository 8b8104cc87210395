// The VIM optimiser (paper §IV): alternate node updates and connectivity swaps that minimise
// E = (1-λ)·E_G/E_G0 + λ·E_D/E_D0 (Eq. 7 with the normalisation of §IV-C) under a quality bound.
// This header is the mesher's public entry point used by the pipeline.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>
#include <vim/element_value.hpp>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim {

#ifdef VIM_CHECKED
inline constexpr bool kCheckedBuild = true;
#else
inline constexpr bool kCheckedBuild = false;
#endif

// Options with the paper's defaults; validate() throws std::invalid_argument naming the option.
struct VimOptions {
  // λ ∈ [0,1): weight of the normalised discretisation energy (§IV-C: "λ = 30% means 30% discretisation,
  // 70% geometry"); the paper does not state the λ of Table I. Default 0.5 (sphere phantom, 100^3
  // voxels, max dihedral <= 150°): TF 5.34% / 2.48% / 0.42% at 125 / 343 / 4096 nodes vs the paper's
  // 5.52% / 2.64% / 0.78% (docs/performance.md). Larger λ trades element quality (min dihedral) for
  // image fit.
  double lambda = 0.5;
  double max_dihedral_deg = 150.0;  // quality bound (3D: max dihedral; 2D: max interior angle), in (90,180)
  double min_dihedral_deg = 0.0;    // optional lower bound (0 = off)
  double min_radius_ratio = 0.0;    // optional normalised radius-ratio lower bound in [0,1) (0 = off)
  int max_iterations = 50;          // cap on node-update + swap sweeps
  double convergence = 1e-3;        // Eq. 9 threshold on v
  // ... and the last iteration lowered E by less than this fraction (0 = Eq. 9 alone, the paper's
  // rule). Eq. 9 is an RMS over all nodes: when most nodes sit in uniform regions (many nodes for
  // the image's features) it falls below 1e-3 while the few image nodes still lower E a lot.
  double energy_convergence = 1e-2;
  double line_search_step = 0.5;  // golden-section stops below this many (minimum) voxel sizes
  // Node-update search width: 0 = a golden-section search toward every direction (the paper's §IV-B);
  // w > 0 = probe every direction at two points and search only the w best in full. Default 3: on the
  // Table I phantom TF 5.40 / 2.29 / 0.40% at 125 / 343 / 4096 nodes (0: 5.35 / 2.32 / 0.41%) in
  // less than half the time at 4096 nodes (docs/performance.md).
  int search_width = 3;
  enum class NodeStrategy { centroid_line_search, random_walk } strategy = NodeStrategy::centroid_line_search;
  int random_walk_samples = 16;  // candidates per node for the random-walk strategy
  bool swaps = true;             // connectivity updates (2D flips; 3D 2-3, 3-2, 4-4)
  int threads = 0;               // 0 = TBB default; results do not depend on it
  std::uint64_t seed = 1;        // random-walk and tie-breaking seed
  int insert_nodes = 0;          // extra nodes to insert near high-cost elements (never above node_budget)
  long node_budget = 0;          // hard cap for insertion (0 = current node count)
  // Check every mesh invariant (invariants.hpp) after each node sweep, swap pass and insertion, and
  // throw vim::InvariantViolation at the first violation. About doubles the time per iteration.
  // Default on in a checked build (cmake -DVIM_CHECKED=ON), off otherwise.
  bool check_invariants = kCheckedBuild;

  void validate() const;
  // The convergence rule: v (Eq. 9) below `convergence` and E, which went from e_before to e_after
  // in the iteration, no longer falling by `energy_convergence` (0: Eq. 9 alone).
  bool converged(double v, double e_before, double e_after) const;
};

struct IterationRecord {
  int iteration = 0;            // 0 = initial mesh
  double energy = 0.0;          // E (normalised, Eq. 7)
  double geometric = 0.0;       // E_G (absolute)
  double discretization = 0.0;  // E_D (absolute)
  double v = 0.0;               // Eq. 9 convergence measure of this iteration's node moves
  long searched = 0;            // nodes whose update ran (the others' 1-rings had not changed)
  long evaluations = 0;         // candidate positions evaluated by the node updates
  long moves = 0;               // accepted node moves
  long swaps = 0;               // accepted connectivity changes
  double seconds = 0.0;         // wall time of the iteration, of which:
  double node_seconds = 0.0;    // the node-update sweep (parallel over colour classes)
  double swap_seconds = 0.0;    // the swap pass (sequential) and the recolouring after it
};

template <int dim>
struct VimResult {
  SimplexMesh<dim> mesh;                 // positively oriented
  std::vector<ElementValue> values;      // one per cell
  std::vector<IterationRecord> history;  // history[0] is the initial mesh
  double eg0 = 0.0, ed0 = 0.0;           // normalisation constants (§IV-C)
  // E_D0 was estimated: the initial mesh's E_D is 0 although the image varies (it fits the image
  // exactly), so E_D0 = |Ω|·var(Ω)·m^(−1/d) for m elements instead of 0, which would switch the image off.
  bool ed0_estimated = false;
  bool converged = false;
  std::vector<std::uint8_t> boundary_kind;  // per node: number of box faces it lies on (dim = corner)
  // optimize_labels only: per cell its label by the majority rule (LabelStatistics::majority).
  std::vector<int> labels;
};

using ProgressCallback = std::function<void(const IterationRecord&)>;

// Runs VIM from `initial` (a mesh of the image box): per iteration one node-update sweep over the
// colour classes of the node graph (parallel within a class, bit-identical for any thread count),
// one sequential swap pass (2D flips; 3D 2-3, 3-2, 4-4) and, if options.insert_nodes, edge splits
// at the highest-cost elements up to options.node_budget; stops when v (Eq. 9) < convergence.
// Every accepted change lowers E, so history[t].energy never increases. Box constraints use the
// initial mesh's bounding box: corners fixed, edge nodes slide along their edge, face nodes within
// their face. E_G0, E_D0 are fixed from `initial`; if E_D0 == 0 (constant image) the image term is
// off and VIM is pure (normalised) ODT smoothing. An initial mesh that fits a varying image exactly
// (E_D = 0) gets an estimated E_D0 instead (VimResult::ed0_estimated). Implementation: optimizer.hpp (state,
// node updates, swaps) and src/vim.cpp (this loop). Throws std::invalid_argument for invalid options, an
// image with < 2 voxels along an axis (the message names the axis), or an initial mesh with an inverted or
// degenerate element. `density` (optional, paper §VI-E "E_G can be modified using a sizing field"): each
// element's E_G is weighted by the density sampled at its centroid during the whole run, so the optimum keeps
// the density's sizing (element size ∝ density^(−1/(dim+2)) where the image is uniform); it is in the mesh's
// frame like `image` (any grid) and must be finite and > 0 (throws otherwise). Without it the geometric term
// drives toward uniform sizes (a sized initial mesh drifts back).
template <int dim>
VimResult<dim> optimize(const Image<dim>& image, SimplexMesh<dim> initial, const VimOptions& options,
                        const ProgressCallback& progress = {}, const Image<dim>* density = nullptr);

// VIM on a label image (docs/labels.md): `labels` holds integer labels on a voxel grid; E_D of an
// element is |τ|·Σ_l var(1_l) (the variance of every label's indicator, summed), with the same
// normalisation, node updates, swaps and quality bound as optimize(). The result's `labels` gives
// every cell the label of most of its voxel centres (the smallest on a tie; an element holding none,
// the label nearest its centroid). `values` (optional, any grid covering the mesh): the cells'
// ElementValue from that image (Eq. 4–6); without it each cell's value is its voxel count, its label
// as the mean and its indicator variance. Throws std::invalid_argument for a non-integer label image
// (naming the voxel) and as optimize() does.
template <int dim>
VimResult<dim> optimize_labels(const Image<dim>& labels, SimplexMesh<dim> initial, const VimOptions& options,
                               const ProgressCallback& progress = {}, const Image<dim>* density = nullptr,
                               const Image<dim>* values = nullptr);

}  // namespace vim

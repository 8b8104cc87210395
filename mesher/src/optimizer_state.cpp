// State of the VIM optimisation (paper §IV): the mesh with its box constraints, the per-element
// caches of E_G (Eq. 3) and E_D (Eq. 6) and their weighted sum E (Eq. 7), the cell slots the swaps
// and insertions reuse, and the from-scratch invariant check. See optimizer.hpp.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vim/energy.hpp>
#include <vim/optimizer.hpp>

namespace vim {

template <int dim>
VimOptimizer<dim>::VimOptimizer(SimplexMesh<dim> mesh, const VoxelStatistics<dim>* stats,
                                const Image<dim>* density, const VimOptions& options,
                                const LabelStatistics<dim>* labels)
    : mesh_(std::move(mesh)), stats_(stats), labels_(labels), density_(density), options_(options) {
  options_.validate();
  if (labels_ && stats_ != &labels_->values())
    throw std::invalid_argument("VimOptimizer: with labels, stats must be the label values' statistics");
  if (mesh_.cells.empty() || mesh_.points.empty()) throw std::invalid_argument("initial mesh is empty");
  for (const auto& cell : mesh_.cells)
    for (int v : cell)
      if (v < 0 || static_cast<std::size_t>(v) >= mesh_.points.size())
        throw std::invalid_argument("initial mesh: cell vertex index out of range");
  QualityBound bound;
  bound.max_dihedral_deg = options_.max_dihedral_deg;
  bound.min_dihedral_deg = options_.min_dihedral_deg;
  bound.min_radius_ratio = options_.min_radius_ratio;
  quality_ = QualityCheck<dim>(bound);

  box_min_ = mesh_.points[0];
  box_max_ = mesh_.points[0];
  for (const auto& p : mesh_.points) {
    box_min_ = box_min_.cwiseMin(p);
    box_max_ = box_max_.cwiseMax(p);
  }
  boundary_tol_ = 1e-9 * (box_max_ - box_min_).norm();
  const Image<dim>* img = stats_ ? &stats_->image() : density_;
  const double voxel = img ? img->min_spacing() : (box_max_ - box_min_).minCoeff() / 100.0;
  min_step_ = options_.line_search_step * voxel;

  dirty_.assign(mesh_.points.size(), 1);
  fixed_.resize(mesh_.points.size());
  for (std::size_t i = 0; i < mesh_.points.size(); ++i) fixed_[i] = classify(mesh_.points[i]);

  alive_.assign(mesh_.cells.size(), 1);
  n_live_ = mesh_.cells.size();
  cache_.resize(mesh_.cells.size());
  for (std::size_t c = 0; c < mesh_.cells.size(); ++c) {
    const Simplex x = simplex(static_cast<int>(c));
    const double vol = signed_volume<dim>(x);
    if (!(vol > 0.0)) {
      std::ostringstream m;
      m << "initial mesh has an inverted or degenerate element: cell " << c << " has signed volume " << vol;
      throw std::invalid_argument(m.str());
    }
    cache_[c] = evaluate(x);
  }
  const MeshQuality start = mesh_quality<dim>(mesh_);
  invariant_bound_ = bound;
  if (bound.min_dihedral_deg > 0.0)
    invariant_bound_.min_dihedral_deg = std::min(bound.min_dihedral_deg, start.min_dihedral_deg);
  if (bound.min_radius_ratio > 0.0)
    invariant_bound_.min_radius_ratio = std::min(bound.min_radius_ratio, start.min_nrr);
  adj_.build(mesh_.points.size(), mesh_.cells);
  fix_normalization();
  recolour();
}

template <int dim>
std::uint8_t VimOptimizer<dim>::classify(const Point& p) const {
  std::uint8_t mask = 0;
  for (int a = 0; a < dim; ++a)
    if (std::abs(p[a] - box_min_[a]) <= boundary_tol_ || std::abs(p[a] - box_max_[a]) <= boundary_tol_)
      mask |= static_cast<std::uint8_t>(1u << a);
  return mask;
}

template <int dim>
double VimOptimizer<dim>::cost_of(const CellCache& c) const {
  return wg_ * c.eg + wd_ * c.ed;
}

template <int dim>
double VimOptimizer<dim>::data_variance(const Simplex& x,
                                        const typename VoxelStatistics<dim>::Sums& s) const {
  const double var = element_variance(s.n, s.s, s.q);
  if (labels_ == nullptr || var == 0.0) return var;
  return labels_->indicator_variance(x);
}

template <int dim>
CellCache VimOptimizer<dim>::evaluate(const Simplex& x) const {
  CellCache c;
  c.volume = signed_volume<dim>(x);
  c.eg = geometric_energy_of_volume<dim>(x, c.volume);
  if (density_) c.eg *= density_->interpolate(centroid<dim>(x));
  if (stats_) {
    // A uniform element (a box of equal voxels) has E_D = 0 exactly and keeps a one-voxel stand-in
    // for its sums (VoxelStatistics::varied_sums), which is all the 1-ring uniformity test needs.
    typename VoxelStatistics<dim>::Sums s;
    const bool varied = stats_->varied_sums(x, s);
    c.n = s.n;
    c.s = s.s;
    c.q = s.q;
    c.ed = varied ? discretization_energy(std::abs(c.volume), data_variance(x, s)) : 0.0;
  }
  c.cost = cost_of(c);
  return c;
}

template <int dim>
EnergyTotals VimOptimizer<dim>::totals() const {
  long double g = 0.0L, d = 0.0L, e = 0.0L;
  for (std::size_t c = 0; c < cache_.size(); ++c) {
    if (!alive_[c]) continue;
    g += cache_[c].eg;
    d += cache_[c].ed;
    e += cache_[c].cost;
  }
  return {static_cast<double>(g), static_cast<double>(d), static_cast<double>(e)};
}

template <int dim>
EnergyTotals VimOptimizer<dim>::recompute_totals() const {
  long double g = 0.0L, d = 0.0L, e = 0.0L;
  for (std::size_t c = 0; c < mesh_.cells.size(); ++c) {
    if (!alive_[c]) continue;
    const CellCache k = evaluate(simplex(static_cast<int>(c)));
    g += k.eg;
    d += k.ed;
    e += k.cost;
  }
  return {static_cast<double>(g), static_cast<double>(d), static_cast<double>(e)};
}

template <int dim>
void VimOptimizer<dim>::check_invariants(const char* stage, int iteration, double previous_energy) const {
  auto fail = [&](const std::string& what) {
    std::ostringstream m;
    m << "mesh invariant violated after the " << stage << " of iteration " << iteration << ": " << what;
    throw InvariantViolation(m.str());
  };
  std::string v = mesh_invariant_violation<dim>(mesh_, alive_, fixed_, box_min_, box_max_, boundary_tol_,
                                                invariant_bound_);
  if (!v.empty()) fail(v);
  if (!adj_.consistent(mesh_.n_points(), mesh_.cells, alive_))
    fail("the node-to-cell adjacency differs from a rebuild");
  const EnergyTotals cached = totals(), fresh = recompute_totals();
  const double scale = std::max(std::abs(fresh.energy), 1e-300);
  if (!(std::abs(cached.energy - fresh.energy) <= 1e-9 * scale)) {
    std::ostringstream m;
    m << "stale per-element caches: cached E = " << cached.energy << ", fresh evaluation " << fresh.energy;
    fail(m.str());
  }
  if (!(cached.energy <= previous_energy + 1e-12 * std::abs(previous_energy))) {
    std::ostringstream m;
    m << "E rose from " << previous_energy << " to " << cached.energy;
    fail(m.str());
  }
}

template <int dim>
SimplexMesh<dim> VimOptimizer<dim>::compact_mesh() const {
  SimplexMesh<dim> out;
  out.points = mesh_.points;
  out.cells.reserve(n_live_);
  for (std::size_t c = 0; c < mesh_.cells.size(); ++c)
    if (alive_[c]) out.cells.push_back(mesh_.cells[c]);
  orient_positively(out);
  return out;
}

template <int dim>
int VimOptimizer<dim>::new_cell_slot() {
  if (!free_.empty()) {
    const int c = free_.back();
    free_.pop_back();
    return c;
  }
  mesh_.cells.emplace_back();
  cache_.emplace_back();
  alive_.push_back(0);
  return static_cast<int>(mesh_.cells.size() - 1);
}

template <int dim>
void VimOptimizer<dim>::set_cell(int c, const Cell& v, const CellCache& cache) {
  mesh_.cells[c] = v;
  cache_[c] = cache;
  for (int w : v) dirty_[w] = 1;
  if (!alive_[c]) ++n_live_;
  alive_[c] = 1;
  adj_.add_cell(c, v);
}

template <int dim>
void VimOptimizer<dim>::mark_ring_dirty(int node) {
  dirty_[node] = 1;
  for (int c : adj_.cells_of(node))
    for (int w : mesh_.cells[c]) dirty_[w] = 1;
}
template class VimOptimizer<2>;
template class VimOptimizer<3>;

}  // namespace vim

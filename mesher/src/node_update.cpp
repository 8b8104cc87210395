// Node updates of paper §IV-B / §VI-D: for node i, golden-section line searches (or a random walk
// inside the 1-ring), evaluating only the 1-ring's energy; the best candidate is taken iff E drops
// and the quality bound holds. Directions: where the image varies inside the 1-ring, toward the
// minimiser of the 1-ring's E_G (the ODT update), the centroid of each 1-ring element whose own
// voxels vary (E_D > 0) and the midpoint of each edge at i; where it is constant (E_D ≡ 0), toward
// the E_G minimiser only, and toward the centroids if that finds no decrease.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vim/energy.hpp>
#include <vim/optimizer.hpp>

namespace vim {

namespace {

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Small deterministic generator seeded per (seed, iteration, node): results do not depend on the
// thread that runs the update.
struct NodeRng {
  std::uint64_t state;
  NodeRng(std::uint64_t seed, int iteration, int node)
      : state(splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(iteration) * 0x100000001B3ull ^
                                           splitmix64(static_cast<std::uint64_t>(node))))) {}
  std::uint64_t next() { return state = splitmix64(state); }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
};

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kGolden = 0.61803398874989484820;

}  // namespace

// Energy of the 1-ring with the node at p (written to s.trial); +inf if an element would be
// inverted or violate the quality bound. The cheap E_G terms are summed first; the voxel sums are
// only taken if `image` and stop as soon as the partial sum exceeds `bound` (the caller then only
// learns "worse than bound"). With image == false the E_D terms are taken as zero.
template <int dim>
double VimOptimizer<dim>::evaluate_candidate(const Point& p, Scratch& s, double bound, bool image) const {
  const std::size_t m = s.ring.size();
  // Cheapest first: orientation, then the E_G terms (a candidate already worse than `bound` needs no
  // quality check: infeasible or not, the caller discards it), then the quality bound, then E_D.
  // A partial sum above `bound` is returned at once: the callers only compare it with `bound` (and
  // with values at least as large), so stopping early cannot change a decision.
  double total = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    CellCache& c = s.trial[k];
    c = CellCache{};
    c.volume = signed_volume<dim>(x);
    if (!(c.volume > 0.0)) return kInf;
    c.eg = geometric_energy_of_volume<dim>(x, c.volume);
    if (density_) c.eg *= density_->interpolate(centroid<dim>(x));
    c.cost = wg_ * c.eg;
    total += c.cost;
    if (total > bound) return total;
  }
  for (std::size_t k = 0; k < m; ++k) {
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    if (!acceptable(x, s.trial[k].volume, &s.faces[k])) return kInf;
  }
  if (!image) return total;
  // The voxel sums dominate the cost. They are taken in s.order (the elements with the largest
  // current E_D first), so a candidate that loses usually stops after a few elements. The early
  // stop needs the partial sum above bound·(1 + 1e-12): the terms are non-negative and the margin is
  // far above the round-off of summing them in another order, so the total in ring order exceeds
  // bound too. A candidate that is not stopped gets its total summed in ring order, E_G first, as
  // the cache and every other evaluation do. The decisions are therefore those of a ring-order loop.
  const double stop = bound * (1.0 + 1e-12);
  double partial = total;
  for (std::size_t r = 0; r < m; ++r) {
    const std::size_t k = static_cast<std::size_t>(s.order[r]);
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    CellCache& c = s.trial[k];
    typename VoxelStatistics<dim>::Sums sum;
    const bool varied = stats_->varied_sums(x, sum);  // as in evaluate()
    c.n = sum.n;
    c.s = sum.s;
    c.q = sum.q;
    c.ed = varied ? discretization_energy(c.volume, data_variance(x, sum)) : 0.0;
    const double d = wd_ * c.ed;
    c.cost += d;
    s.ed_cost[k] = d;
    partial += d;
    if (partial > stop) return partial;
  }
  for (std::size_t k = 0; k < m; ++k) total += s.ed_cost[k];
  return total;
}

// One node's search (§IV-B): candidate positions of the node, each evaluated on the 1-ring, and the
// best so far. A candidate must beat the current 1-ring energy by a relative margin far above
// round-off (`best` starts at that threshold), so accepted moves strictly lower E and the recorded
// history never increases.
template <int dim>
struct VimOptimizer<dim>::NodeSearch {
  const VimOptimizer& opt;
  Scratch& s;
  Point x0;            // the node's position
  std::uint8_t mask;   // fixed axes (box constraints)
  bool image;          // E_D varies in the 1-ring: take the voxel sums
  double best;         // the best value so far (the threshold until a candidate beats it)
  Point best_p = x0;   // its position
  bool found = false;  // a candidate beat the threshold
  double tiny = 1e-12 * opt.bbox_diagonal();

  double consider(const Point& p, double bound) {
    ++s.evaluations;
    const double f = opt.evaluate_candidate(p, s, bound, image);
    if (f < best) {
      best = f;
      best_p = p;
      std::swap(s.trial, s.best);
      found = true;
    }
    return f;
  }
  Point project(Point d) const {
    for (int a = 0; a < dim; ++a)
      if (mask & (1u << a)) d[a] = 0.0;
    return d;
  }

  // Screening (search_width = w > 0, when there are more than w directions): each direction is
  // probed at the first interior point of its golden-section search, t = 1 − φ⁻¹, and at
  // (1 − φ⁻¹)², nearer the node; only the w directions with the lowest probe values are then
  // searched in full. A probe already above the w-th lowest so far stops early (its value only
  // decides that it is not kept). Every probe is a candidate like any other. The first probe is the
  // golden-section search's first interior point, so its exact value (when it was not stopped
  // early) is handed to the search of a kept direction (s.known_f1, NaN if none) instead of being
  // evaluated again.
  void screen() {
    std::vector<Point>& dirs = s.dirs;
    s.known_f1.clear();
    const std::size_t w = static_cast<std::size_t>(opt.options_.search_width);
    if (w == 0 || dirs.size() <= w) return;
    auto& top = s.top;  // ascending by probe value, at most w
    top.clear();
    for (std::size_t k = 0; k < dirs.size(); ++k) {
      const Point d = project(dirs[k] - x0);
      if (d.norm() <= tiny) continue;
      const double bound = top.size() < w ? kInf : top.back().value;
      const double f1 = consider(x0 + (1.0 - kGolden) * d, bound);
      const double f =
          std::min(f1, consider(x0 + ((1.0 - kGolden) * (1.0 - kGolden)) * d, std::min(bound, f1)));
      if (top.size() == w && !(f < top.back().value)) continue;
      if (top.size() == w) top.pop_back();
      top.push_back({f, f1 <= bound ? f1 : std::numeric_limits<double>::quiet_NaN(), k});
      for (std::size_t r = top.size() - 1; r > 0 && top[r].value < top[r - 1].value; --r)
        std::swap(top[r], top[r - 1]);
    }
    s.kept.clear();
    for (const auto& t : top) {
      s.kept.push_back(dirs[t.direction]);
      s.known_f1.push_back(t.f1);
    }
    dirs.swap(s.kept);
  }

  // Golden-section search on t ∈ [0, 1] along x0 + t·d, d = target − x0, from the target (t = 1)
  // down to a bracket shorter than the minimum step; infeasible points count as +inf (shrink toward
  // x0). Each new point is evaluated with the retained point's value as bound: if it is worse, the
  // (partial) value only decides the comparison and is discarded, so the search is exact.
  void golden_section(const Point& d, double len, double known_f1) {
    consider(x0 + d, best);
    double a = 0.0, b = 1.0;
    double t1 = b - kGolden * (b - a), t2 = a + kGolden * (b - a);
    double f1 = !std::isnan(known_f1) ? known_f1 : consider(x0 + t1 * d, kInf);
    double f2 = consider(x0 + t2 * d, f1);
    while ((b - a) * len > opt.min_step_) {
      if (f1 <= f2) {
        b = t2;
        t2 = t1;
        f2 = f1;
        t1 = b - kGolden * (b - a);
        f1 = consider(x0 + t1 * d, f2);
      } else {
        a = t1;
        t1 = t2;
        f1 = f2;
        t2 = a + kGolden * (b - a);
        f2 = consider(x0 + t2 * d, f1);
      }
    }
  }

  // Screens s.dirs, then searches toward each kept target.
  void search() {
    screen();
    const std::vector<Point>& dirs = s.dirs;
    for (std::size_t k = 0; k < dirs.size(); ++k) {
      const Point d = project(dirs[k] - x0);
      const double len = d.norm();
      if (len <= tiny) continue;
      golden_section(d, len,
                     k < s.known_f1.size() ? s.known_f1[k] : std::numeric_limits<double>::quiet_NaN());
    }
  }

  // Without a density, E_G of the 1-ring is a quadratic in the node's position while no element
  // inverts: each |τ| is affine in it and the 1-ring's union is fixed (along the node's face or edge
  // on the boundary). Its minimiser is the ODT update (Chen & Xu) x* = x0 − G / (2|Ω|),
  // G = Σ_τ ∇|τ|·Σ_{k∈τ, k≠i} |x_k − x0|². Returns false if the 1-ring has no volume.
  bool odt_point(Point* odt) const {
    Point g = Point::Zero();
    double omega = 0.0;
    for (std::size_t k = 0; k < s.ring.size(); ++k) {
      const Simplex& x = s.base[k];
      const int v = s.local[k];
      double sq = 0.0;
      for (int j = 0; j <= dim; ++j)
        if (j != v) sq += (x[j] - x0).squaredNorm();
      Point grad;  // ∂|τ|/∂x_v: the opposite face's normal scaled by its measure / dim, toward v
      if constexpr (dim == 3) {
        grad = s.faces[k].normal / 6.0;
      } else {
        const Point e = x[(v + 2) % 3] - x[(v + 1) % 3];
        grad = Point(-e[1], e[0]) / 2.0;
      }
      if (grad.dot(x0 - x[(v + 1) % (dim + 1)]) < 0.0) grad = -grad;
      g += sq * grad;
      omega += std::abs(opt.cache_[s.ring[k]].volume);
    }
    if (!(omega > 0.0)) return false;
    *odt = x0 - g / (2.0 * omega);
    return true;
  }

  // The per-element targets: the ODT point (if not x0 and the image varies), the centroid of each
  // 1-ring element whose own voxels vary (every element where the image is constant in the 1-ring)
  // and, where the image varies, the midpoint of each edge at the node. A uniform element's centroid
  // is not searched where the image varies: moving into it only shrinks it (E_G, which the ODT
  // direction covers) and cannot lower its E_D = 0. On the Table I phantom this drops ~3/4 of the
  // centroid directions of the image nodes (docs/performance.md).
  void ring_targets(const Point& odt) {
    std::vector<Point>& dirs = s.dirs;
    const std::size_t m = s.ring.size();
    dirs.clear();
    if (image && odt != x0) dirs.push_back(odt);
    for (std::size_t k = 0; k < m; ++k)
      if (!(image && opt.cache_[s.ring[k]].ed == 0.0)) dirs.push_back(centroid<dim>(s.base[k]));
    for (std::size_t k = 0; k < m && image; ++k)
      for (int j = 0; j <= dim; ++j) {
        if (j == s.local[k]) continue;
        const Point mid = 0.5 * (s.base[k][j] + x0);
        bool seen = false;
        for (std::size_t q = 0; q < dirs.size() && !seen; ++q) seen = dirs[q] == mid;
        if (!seen) dirs.push_back(mid);
      }
  }

  // The line-search strategy (see the top of the file). Where E_D ≡ 0, one line search toward the
  // ODT point (the quality bound may cut it short) replaces the per-element targets, which are
  // still searched if it finds no decrease; elsewhere the ODT point is one more target.
  void line_searches() {
    bool searched_odt = false;
    Point odt = x0;
    if (opt.density_ == nullptr && odt_point(&odt) && !image) {
      s.dirs.assign(1, odt);
      search();
      searched_odt = true;
    }
    if (!searched_odt || !found) {
      ring_targets(odt);
      search();
    }
  }

  // Random walk: uniformly distributed points of uniformly chosen 1-ring elements (projected onto
  // the node's face/edge on the boundary).
  void random_walk(int iteration, int node) {
    NodeRng rng(opt.options_.seed, iteration, node);
    const std::size_t m = s.ring.size();
    for (int sample = 0; sample < opt.options_.random_walk_samples; ++sample) {
      const std::size_t k = static_cast<std::size_t>(rng.next() % m);
      std::array<double, dim + 1> w;
      double sum = 0.0;
      for (int j = 0; j <= dim; ++j) sum += (w[j] = -std::log(rng.uniform()));
      Point p = Point::Zero();
      for (int j = 0; j <= dim; ++j) p += (w[j] / sum) * s.base[k][j];
      consider(x0 + project(p - x0), best);
    }
  }
};

// Loads node's 1-ring into s (cells, local index of the node, vertices, fixed faces, the order by
// decreasing current E_D) and returns its current energy (0 for an empty ring). *image: the voxels
// in the 1-ring's union vary, so candidates need their voxel sums.
template <int dim>
double VimOptimizer<dim>::load_ring(int node, Scratch& s, bool* image) const {
  const auto& ring = adj_.cells_of(node);
  const std::size_t m = ring.size();
  if (m == 0) return 0.0;
  s.ring.assign(ring.begin(), ring.end());
  s.local.resize(m);
  s.base.resize(m);
  s.trial.resize(m);
  s.best.resize(m);
  s.faces.resize(m);
  double c0 = 0.0;
  long ring_n = 0;
  double ring_s = 0.0, ring_q = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    const int c = s.ring[k];
    s.base[k] = simplex(c);
    for (int j = 0; j <= dim; ++j)
      if (mesh_.cells[c][j] == node) s.local[k] = j;
    s.faces[k] = fixed_face<dim>(s.base[k], s.local[k]);
    c0 += cache_[c].cost;
    ring_n += cache_[c].n;
    ring_s += cache_[c].s;
    ring_q += cache_[c].q;
  }
  s.ed_cost.resize(m);
  s.order.resize(m);
  for (std::size_t k = 0; k < m; ++k) {  // insertion sort by decreasing current E_D, then position
    std::size_t r = k;
    const double e = cache_[s.ring[k]].ed;
    for (; r > 0 && cache_[s.ring[static_cast<std::size_t>(s.order[r - 1])]].ed < e; --r)
      s.order[r] = s.order[r - 1];
    s.order[r] = static_cast<int>(k);
  }
  // Moving the node keeps the 1-ring's union fixed, so if the voxels in it are all equal (variance
  // zero up to round-off), E_D is zero for every candidate and the search skips the voxel sums.
  // (Uniform elements contribute a one-voxel stand-in of their value: the variance is still zero iff
  // every value is equal; an empty element whose box holds another value only makes this stricter.)
  *image = stats_ != nullptr && wd_ > 0.0 && element_variance(ring_n, ring_s, ring_q) != 0.0;
  return c0;
}

template <int dim>
bool VimOptimizer<dim>::update_node_impl(int node, int iteration, Scratch& s, double* moved_sq) {
  s.evaluations = 0;
  const std::uint8_t mask = fixed_[node];
  if (mask == (1u << dim) - 1) return false;  // corner
  bool image = false;
  const double c0 = load_ring(node, s, &image);
  if (!(c0 > 0.0)) return false;
  const bool exact = image || stats_ == nullptr;  // otherwise the winner is re-evaluated exactly
  const double threshold = c0 * (1.0 - 1e-12);
  NodeSearch search{*this, s, mesh_.points[node], mask, image, threshold};
  if (options_.strategy == VimOptions::NodeStrategy::centroid_line_search)
    search.line_searches();
  else
    search.random_walk(iteration, node);
  if (!search.found) return false;
  const std::size_t m = s.ring.size();
  if (!exact) {
    // The search skipped the voxel sums: evaluate the winner exactly and re-check the decrease.
    double total = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      Simplex x = s.base[k];
      x[s.local[k]] = search.best_p;
      s.best[k] = evaluate(x);
      total += s.best[k].cost;
    }
    if (!(total < threshold)) return false;
  }
  mesh_.points[node] = search.best_p;
  for (std::size_t k = 0; k < m; ++k) cache_[s.ring[k]] = s.best[k];
  if (moved_sq) *moved_sq = (search.best_p - search.x0).squaredNorm();
  return true;
}

template <int dim>
long VimOptimizer<dim>::update_nodes(int iteration, double* sum_sq, long* searched, long* evaluations) {
  const std::size_t n = mesh_.points.size();
  std::vector<double> moved(n, 0.0);
  std::vector<long> evals(n, 0);
  std::vector<char> did(n, 0), ran(n, 0);
  const bool line_search = options_.strategy == VimOptions::NodeStrategy::centroid_line_search;
  tbb::task_arena arena(options_.threads > 0 ? options_.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    for (const auto& cls : colours_) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cls.size()),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          Scratch& s = scratch_.local();
                          for (std::size_t j = r.begin(); j != r.end(); ++j) {
                            const int node = cls[j];
                            if (line_search && !dirty_[node])
                              continue;        // would repeat its last, unsuccessful search
                            dirty_[node] = 0;  // only this task touches this node's flag during the class
                            ran[node] = 1;
                            double sq = 0.0;
                            const bool moved_node = update_node_impl(node, iteration, s, &sq);
                            evals[node] = s.evaluations;
                            if (moved_node) {
                              did[node] = 1;
                              moved[node] = sq;
                            }
                          }
                        });
      for (int node : cls)  // sequential: neighbours of moved nodes must search again
        if (did[node]) mark_ring_dirty(node);
    }
  });
  long moves = 0, runs = 0, evaluated = 0;
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    evaluated += evals[i];
    moves += did[i];
    runs += ran[i];
    total += moved[i];
  }
  if (sum_sq) *sum_sq = total;
  if (searched) *searched = runs;
  if (evaluations) *evaluations = evaluated;
  return moves;
}

template double VimOptimizer<2>::evaluate_candidate(const Point&, Scratch&, double, bool) const;
template double VimOptimizer<3>::evaluate_candidate(const Point&, Scratch&, double, bool) const;
template double VimOptimizer<2>::load_ring(int, Scratch&, bool*) const;
template double VimOptimizer<3>::load_ring(int, Scratch&, bool*) const;
template bool VimOptimizer<2>::update_node_impl(int, int, Scratch&, double*);
template bool VimOptimizer<3>::update_node_impl(int, int, Scratch&, double*);
template long VimOptimizer<2>::update_nodes(int, double*, long*, long*);
template long VimOptimizer<3>::update_nodes(int, double*, long*, long*);

}  // namespace vim

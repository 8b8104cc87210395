// Node updates of paper §IV-B / §VI-D: for node i, golden-section line searches toward the
// centroid of each 1-ring element (or a random walk inside the 1-ring), evaluating only the
// 1-ring's energy; the best candidate is taken iff E drops and the quality bound holds.
#include <vim/optimizer.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>

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
// inverted or violate the quality bound. Stops early once the partial sum reaches `bound`.
template <int dim>
double VimOptimizer<dim>::evaluate_candidate(const Point& p, Scratch& s, double bound) const {
  const std::size_t m = s.ring.size();
  // Cheap rejections first: orientation of every element, then the quality bound.
  for (std::size_t k = 0; k < m; ++k) {
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    if (!(signed_volume<dim>(x) > 0.0)) return kInf;
  }
  for (std::size_t k = 0; k < m; ++k) {
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    if (!acceptable(x)) return kInf;
  }
  double total = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    Simplex x = s.base[k];
    x[s.local[k]] = p;
    s.trial[k] = evaluate(x);
    total += s.trial[k].cost;
    if (total >= bound) return total;
  }
  return total;
}

template <int dim>
bool VimOptimizer<dim>::update_node_impl(int node, int iteration, Scratch& s, double* moved_sq) {
  const std::uint8_t mask = fixed_[node];
  if (mask == (1u << dim) - 1) return false;  // corner
  const auto& ring = adj_.cells_of(node);
  const std::size_t m = ring.size();
  if (m == 0) return false;
  s.ring.assign(ring.begin(), ring.end());
  s.local.resize(m);
  s.base.resize(m);
  s.trial.resize(m);
  s.best.resize(m);
  double c0 = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    const int c = s.ring[k];
    s.base[k] = simplex(c);
    for (int j = 0; j <= dim; ++j)
      if (mesh_.cells[c][j] == node) s.local[k] = j;
    c0 += cache_[c].cost;
  }
  if (!(c0 > 0.0)) return false;
  const Point x0 = mesh_.points[node];

  // A candidate must beat the current 1-ring energy by a relative margin far above round-off, so
  // accepted moves strictly lower E and the recorded history never increases.
  const double threshold = c0 * (1.0 - 1e-12);
  double best = threshold;
  Point best_p = x0;
  bool found = false;
  auto consider = [&](const Point& p, double bound) {
    const double f = evaluate_candidate(p, s, bound);
    if (f < best) {
      best = f;
      best_p = p;
      std::swap(s.trial, s.best);
      found = true;
    }
    return f;
  };
  auto project = [&](Point d) {
    for (int a = 0; a < dim; ++a)
      if (mask & (1u << a)) d[a] = 0.0;
    return d;
  };

  if (options_.strategy == VimOptions::NodeStrategy::centroid_line_search) {
    const double tiny = 1e-12 * bbox_diagonal();
    for (std::size_t k = 0; k < m; ++k) {
      const Point d = project(centroid<dim>(s.base[k]) - x0);
      const double len = d.norm();
      if (len <= tiny) continue;
      // Golden-section search on t ∈ [0, 1] along x0 + t·d, from the centroid (t = 1) down to a
      // bracket shorter than the minimum step; infeasible points count as +inf (shrink toward x0).
      consider(x0 + d, kInf);
      double a = 0.0, b = 1.0;
      double t1 = b - kGolden * (b - a), t2 = a + kGolden * (b - a);
      double f1 = consider(x0 + t1 * d, kInf), f2 = consider(x0 + t2 * d, kInf);
      while ((b - a) * len > min_step_) {
        if (f1 <= f2) {
          b = t2;
          t2 = t1;
          f2 = f1;
          t1 = b - kGolden * (b - a);
          f1 = consider(x0 + t1 * d, kInf);
        } else {
          a = t1;
          t1 = t2;
          f1 = f2;
          t2 = a + kGolden * (b - a);
          f2 = consider(x0 + t2 * d, kInf);
        }
      }
    }
  } else {
    // Random walk: uniformly distributed points of uniformly chosen 1-ring elements (projected onto
    // the node's face/edge on the boundary).
    NodeRng rng(options_.seed, iteration, node);
    for (int sample = 0; sample < options_.random_walk_samples; ++sample) {
      const std::size_t k = static_cast<std::size_t>(rng.next() % m);
      std::array<double, dim + 1> w;
      double sum = 0.0;
      for (int j = 0; j <= dim; ++j) sum += (w[j] = -std::log(rng.uniform()));
      Point p = Point::Zero();
      for (int j = 0; j <= dim; ++j) p += (w[j] / sum) * s.base[k][j];
      consider(x0 + project(p - x0), best);
    }
  }

  if (!found) return false;
  mesh_.points[node] = best_p;
  for (std::size_t k = 0; k < m; ++k) cache_[s.ring[k]] = s.best[k];
  if (moved_sq) *moved_sq = (best_p - x0).squaredNorm();
  return true;
}

template <int dim>
bool VimOptimizer<dim>::update_node(int node, int iteration) {
  return update_node_impl(node, iteration, scratch_.local(), nullptr);
}

// One sweep: colour classes in order; nodes of a class in parallel (their 1-rings are disjoint, so
// the result does not depend on the thread count or scheduling).
template <int dim>
long VimOptimizer<dim>::update_nodes(int iteration, double* sum_sq) {
  const std::size_t n = mesh_.points.size();
  std::vector<double> moved(n, 0.0);
  std::vector<char> did(n, 0);
  tbb::task_arena arena(options_.threads > 0 ? options_.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    for (const auto& cls : colours_) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cls.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        Scratch& s = scratch_.local();
        for (std::size_t j = r.begin(); j != r.end(); ++j) {
          const int node = cls[j];
          double sq = 0.0;
          if (update_node_impl(node, iteration, s, &sq)) {
            did[node] = 1;
            moved[node] = sq;
          }
        }
      });
    }
  });
  long moves = 0;
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    moves += did[i];
    total += moved[i];
  }
  if (sum_sq) *sum_sq = total;
  return moves;
}

template double VimOptimizer<2>::evaluate_candidate(const Point&, Scratch&, double) const;
template double VimOptimizer<3>::evaluate_candidate(const Point&, Scratch&, double) const;
template bool VimOptimizer<2>::update_node_impl(int, int, Scratch&, double*);
template bool VimOptimizer<3>::update_node_impl(int, int, Scratch&, double*);
template bool VimOptimizer<2>::update_node(int, int);
template bool VimOptimizer<3>::update_node(int, int);
template long VimOptimizer<2>::update_nodes(int, double*);
template long VimOptimizer<3>::update_nodes(int, double*);

}  // namespace vim

// Optional node insertion (paper §VI-D: "nodes can also be added ... near elements contributing a
// higher cost E"): split the longest edge of the highest-cost elements at its midpoint, splitting
// every cell that shares the edge so the mesh stays conforming. Never exceeds the caller's budget.
#include <algorithm>
#include <numeric>
#include <vim/optimizer.hpp>

namespace vim {

template <int dim>
long VimOptimizer<dim>::insert_nodes(long k) {
  if (k <= 0) return 0;
  std::vector<int> order;
  for (std::size_t c = 0; c < mesh_.cells.size(); ++c)
    if (alive_[c]) order.push_back(static_cast<int>(c));
  const std::size_t top = std::min<std::size_t>(order.size(), static_cast<std::size_t>(k));
  std::partial_sort(order.begin(), order.begin() + top, order.end(), [&](int x, int y) {
    return cache_[x].cost > cache_[y].cost || (cache_[x].cost == cache_[y].cost && x < y);
  });
  order.resize(top);

  long inserted = 0;
  std::vector<int> ring;
  for (int c : order) {
    if (!alive_[c]) continue;
    const Cell v = mesh_.cells[c];
    int ia = 0, ib = 1;
    double longest = -1.0;
    for (int i = 0; i <= dim; ++i)
      for (int j = i + 1; j <= dim; ++j) {
        const double l = (mesh_.points[v[i]] - mesh_.points[v[j]]).squaredNorm();
        if (l > longest) {
          longest = l;
          ia = i;
          ib = j;
        }
      }
    const int a = v[ia], b = v[ib];
    adj_.cells_with_edge(a, b, ring);
    const Point mid = 0.5 * (mesh_.points[a] + mesh_.points[b]);
    const int m = static_cast<int>(mesh_.points.size());
    adj_.add_point();  // first: throws beyond the node limit before the mesh changes
    mesh_.points.push_back(mid);
    fixed_.push_back(classify(mid));
    dirty_.push_back(1);
    std::vector<Cell> split;
    for (int rc : ring) {
      Cell w1 = mesh_.cells[rc], w2 = mesh_.cells[rc];
      for (int j = 0; j <= dim; ++j) {
        if (w1[j] == a) w1[j] = m;
        if (w2[j] == b) w2[j] = m;
      }
      split.push_back(w1);
      split.push_back(w2);
    }
    if (try_replace(ring.data(), static_cast<int>(ring.size()), split.data(), 1,
                    static_cast<int>(split.size()))) {
      ++inserted;
    } else {
      mesh_.points.pop_back();
      fixed_.pop_back();
      dirty_.pop_back();
      adj_.pop_point();
    }
  }
  return inserted;
}

template long VimOptimizer<2>::insert_nodes(long);
template long VimOptimizer<3>::insert_nodes(long);

}  // namespace vim

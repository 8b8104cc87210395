// Sampling the embedded shaft points along a straight path (vim/needle/shaft.hpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vim/needle/shaft.hpp>

namespace vim::needle {

template <int dim>
std::vector<ShaftPoint<dim>> sample_shaft(const CellLocator<dim>& locator,
                                          const Eigen::Matrix<double, dim, 1>& entry,
                                          const Eigen::Matrix<double, dim, 1>& axis, double depth,
                                          double pitch, const std::vector<bool>& blocked,
                                          bool snap_to_vertices) {
  if (!(pitch > 0.0) || !(depth > 0.0))
    throw std::invalid_argument("sample_shaft: depth and pitch must be > 0");
  // Candidates every pitch. With snap_to_vertices, where the path runs along mesh edges (every vertex
  // of a candidate's support lies on the path's line), the candidate is replaced by those vertices,
  // each at its own arc length: a chain of points inside consecutive collinear edges makes nearly
  // dependent rows (each interpolates between its edge's two vertices; condition number > 1e10 along
  // a 2D box edge), while the vertices themselves are exactly the tissue on the path.
  struct Candidate {
    double s;
    Eigen::Matrix<double, dim, 1> x;
    std::vector<int> sup;
  };
  std::vector<Candidate> cand;
  std::vector<int> sup;
  const double line_tol = 1e-9 * std::max(locator.mean_edge_length(), depth);
  const long n = static_cast<long>(std::ceil(depth / pitch - 1e-9));
  for (long i = 0; i < n; ++i) {
    const double s = static_cast<double>(i) * pitch;
    const Eigen::Matrix<double, dim, 1> x = entry + s * axis;
    if (locator.locate(x, &sup) < 0 || sup.empty()) continue;
    bool along = snap_to_vertices && sup.size() > 1;  // every support vertex on the path, within its depth
    for (std::size_t k = 0; k < sup.size() && along; ++k) {
      const Eigen::Matrix<double, dim, 1> r = locator.vertex(sup[k]) - entry;
      const double sv = r.dot(axis);
      along = (r - sv * axis).norm() <= line_tol && sv >= -line_tol && sv < depth;
    }
    if (along) {
      for (int v : sup)
        cand.push_back({std::max(0.0, (locator.vertex(v) - entry).dot(axis)), locator.vertex(v), {v}});
    } else {
      cand.push_back({s, x, sup});
    }
  }
  std::stable_sort(cand.begin(), cand.end(),
                   [](const Candidate& a, const Candidate& b) { return a.s < b.s; });
  std::vector<ShaftPoint<dim>> pts;
  std::vector<int> last;
  for (const auto& c : cand) {
    // Only the free vertices of the support carry the point's constraint (the blocked ones are held by
    // Dirichlet conditions): a point whose free vertices are those of the last point, or some of them,
    // would constrain the same few DoFs again (a conflict, e.g. where the path enters a held region).
    std::vector<int> free;
    for (int v : c.sup)
      if (!(static_cast<std::size_t>(v) < blocked.size() && blocked[v])) free.push_back(v);
    if (free.empty()) continue;
    if (free == last) continue;
    if (std::includes(last.begin(), last.end(), free.begin(), free.end()) && !last.empty()) continue;
    pts.push_back({c.x, c.s, 0.0});
    last = free;
  }
  for (std::size_t j = 0; j < pts.size(); ++j) {
    const double a = j == 0 ? 0.0 : 0.5 * (pts[j - 1].s + pts[j].s);
    const double b = j + 1 == pts.size() ? depth : 0.5 * (pts[j].s + pts[j + 1].s);
    pts[j].length = b - a;
  }
  return pts;
}

template std::vector<ShaftPoint<2>> sample_shaft<2>(const CellLocator<2>&, const Eigen::Matrix<double, 2, 1>&,
                                                    const Eigen::Matrix<double, 2, 1>&, double, double,
                                                    const std::vector<bool>&, bool);
template std::vector<ShaftPoint<3>> sample_shaft<3>(const CellLocator<3>&, const Eigen::Matrix<double, 3, 1>&,
                                                    const Eigen::Matrix<double, 3, 1>&, double, double,
                                                    const std::vector<bool>&, bool);

}  // namespace vim::needle

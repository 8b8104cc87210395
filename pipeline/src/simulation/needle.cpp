// Needle geometry (docs/architecture.md): shaft sampling, the axial stiffness map used for force control by
// the stick-slip and force models, and the needle-path mesh density (see needle.hpp).
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vim/pipeline/simulation/needle.hpp>

namespace vim::pipeline {

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

AxialMap AxialMap::probe(Eigen::Index m, const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& forces,
                         double sigma) {
  if (!(sigma > 0.0)) throw std::invalid_argument("AxialMap::probe: sigma must be > 0");
  AxialMap map;
  map.c = forces(Eigen::VectorXd::Zero(m));
  map.K.resize(m, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(m);
    e[j] = sigma;
    map.K.col(j) = (forces(e) - map.c) / sigma;
  }
  map.K = (0.5 * (map.K + map.K.transpose())).eval();  // symmetric up to round-off
  return map;
}

void AxialMap::solve_free(Eigen::VectorXd& w, const std::vector<bool>& free,
                          const Eigen::VectorXd& target) const {
  std::vector<Eigen::Index> f, n;
  for (Eigen::Index j = 0; j < w.size(); ++j) (free[j] ? f : n).push_back(j);
  if (f.empty()) return;
  Eigen::MatrixXd kff(f.size(), f.size());
  Eigen::VectorXd rhs(f.size());
  for (std::size_t a = 0; a < f.size(); ++a) {
    rhs[a] = target[f[a]] - c[f[a]];
    for (Eigen::Index j : n) rhs[a] -= K(f[a], j) * w[j];
    for (std::size_t b = 0; b < f.size(); ++b) kff(a, b) = K(f[a], f[b]);
  }
  const Eigen::VectorXd x = kff.ldlt().solve(rhs);
  for (std::size_t a = 0; a < f.size(); ++a) w[f[a]] = x[a];
}

template <int dim>
Image<dim> needle_density(const Image<dim>& like, const std::vector<NeedlePath<dim>>& paths,
                          double size_ratio, double radius) {
  if (!(size_ratio > 0.0 && size_ratio <= 1.0))
    throw std::invalid_argument("needle refinement size_ratio must be in (0, 1], got " +
                                std::to_string(size_ratio));
  if (!(radius > 0.0 && std::isfinite(radius)))
    throw std::invalid_argument("needle refinement radius must be > 0, got " + std::to_string(radius));
  if (paths.empty()) throw std::invalid_argument("needle refinement needs at least one needle path");
  const double peak = std::pow(size_ratio, -static_cast<double>(dim + 2));
  Image<dim> rho(like.size, like.spacing, like.origin, 1.0f);
  for (std::size_t k = 0; k < rho.data.size(); ++k) {
    const auto p = rho.point_of(rho.index_of(k));
    double d = std::numeric_limits<double>::infinity();
    for (const auto& path : paths) d = std::min(d, path.distance(p));
    const double r = d / radius;
    rho.data[k] = static_cast<float>(1.0 + (peak - 1.0) * std::exp(-r * r));
  }
  return rho;
}

template Image<2> needle_density<2>(const Image<2>&, const std::vector<NeedlePath<2>>&, double, double);
template Image<3> needle_density<3>(const Image<3>&, const std::vector<NeedlePath<3>>&, double, double);
template std::vector<ShaftPoint<2>> sample_shaft<2>(const CellLocator<2>&, const Eigen::Matrix<double, 2, 1>&,
                                                    const Eigen::Matrix<double, 2, 1>&, double, double,
                                                    const std::vector<bool>&, bool);
template std::vector<ShaftPoint<3>> sample_shaft<3>(const CellLocator<3>&, const Eigen::Matrix<double, 3, 1>&,
                                                    const Eigen::Matrix<double, 3, 1>&, double, double,
                                                    const std::vector<bool>&, bool);

}  // namespace vim::pipeline

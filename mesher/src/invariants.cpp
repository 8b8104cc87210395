// Mesh invariants (invariants.hpp): a from-scratch check of node placement, cell validity and
// quality, and conformity of the live cells of a VIM mesh of the image box.
#include <vim/invariants.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

namespace vim {
namespace {

template <int dim>
std::string point_text(const Eigen::Matrix<double, dim, 1>& p) {
  std::ostringstream s;
  s << "(";
  for (int a = 0; a < dim; ++a) s << (a ? ", " : "") << p[a];
  s << ")";
  return s.str();
}

// FNV-1a over the dim sorted vertex indices of a facet (the map compares the keys exactly).
template <int dim>
struct FacetHash {
  std::size_t operator()(const std::array<int, dim>& f) const {
    std::size_t h = 1469598103934665603ull;
    for (int v : f) h = (h ^ static_cast<std::size_t>(v)) * 1099511628211ull;
    return h;
  }
};

}  // namespace

template <int dim>
std::string mesh_invariant_violation(const SimplexMesh<dim>& mesh, const std::vector<char>& alive,
                                     const std::vector<std::uint8_t>& fixed_axes,
                                     const Eigen::Matrix<double, dim, 1>& box_min,
                                     const Eigen::Matrix<double, dim, 1>& box_max, double tol,
                                     const QualityBound& bound, double slack_deg) {
  std::ostringstream m;
  const long n_points = static_cast<long>(mesh.points.size());
  for (long i = 0; i < n_points; ++i) {
    const auto& p = mesh.points[i];
    for (int a = 0; a < dim; ++a) {
      if (!(p[a] >= box_min[a] - tol && p[a] <= box_max[a] + tol)) {
        m << "node " << i << " at " << point_text<dim>(p) << " is outside the box along axis " << a << " ["
          << box_min[a] << ", " << box_max[a] << "]";
        return m.str();
      }
      if (!fixed_axes.empty() && (fixed_axes[i] >> a & 1u) && std::abs(p[a] - box_min[a]) > tol &&
          std::abs(p[a] - box_max[a]) > tol) {
        m << "boundary node " << i << " at " << point_text<dim>(p) << " left its box face along axis " << a;
        return m.str();
      }
    }
  }

  using Facet = std::array<int, dim>;
  std::unordered_map<Facet, int, FacetHash<dim>> facet_count;
  long double volume = 0.0L;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    if (!alive.empty() && !alive[c]) continue;
    auto v = mesh.cells[c];
    for (int k = 0; k <= dim; ++k)
      if (v[k] < 0 || v[k] >= n_points) {
        m << "cell " << c << " has vertex index " << v[k] << " outside [0, " << n_points << ")";
        return m.str();
      }
    auto sorted = v;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      m << "cell " << c << " repeats a vertex";
      return m.str();
    }
    const auto x = cell_points(mesh, c);
    const double vol = signed_volume<dim>(x);
    if (!(vol > 0.0)) {
      m << "cell " << c << " is inverted or degenerate (signed volume " << vol << ")";
      return m.str();
    }
    volume += vol;
    const double amax = max_dihedral_deg<dim>(x), amin = min_dihedral_deg<dim>(x);
    if (!(amax <= bound.max_dihedral_deg + slack_deg)) {
      m << "cell " << c << " breaks the quality bound: max " << (dim == 3 ? "dihedral" : "interior")
        << " angle " << amax << "° > " << bound.max_dihedral_deg << "°";
      return m.str();
    }
    if (bound.min_dihedral_deg > 0.0 && !(amin >= bound.min_dihedral_deg - slack_deg)) {
      m << "cell " << c << " breaks the quality bound: min angle " << amin << "° < " << bound.min_dihedral_deg << "°";
      return m.str();
    }
    if (bound.min_radius_ratio > 0.0) {
      const double r = normalized_radius_ratio<dim>(x);
      if (!(r >= bound.min_radius_ratio - 1e-9)) {
        m << "cell " << c << " breaks the quality bound: radius ratio " << r << " < " << bound.min_radius_ratio;
        return m.str();
      }
    }
    for (int skip = 0; skip <= dim; ++skip) {
      Facet f;
      for (int k = 0, j = 0; k <= dim; ++k)
        if (k != skip) f[j++] = sorted[k];
      if (++facet_count[f] > 2) {
        m << "facet of cell " << c << " is shared by more than two cells (overlapping cells)";
        return m.str();
      }
    }
  }
  for (const auto& [f, count] : facet_count) {
    if (count != 1) continue;
    // A facet of one cell must lie on one box face: all its vertices on the same side of one axis.
    bool on_face = false;
    for (int a = 0; a < dim && !on_face; ++a)
      for (const double side : {box_min[a], box_max[a]}) {
        bool all = true;
        for (int v : f) all = all && std::abs(mesh.points[v][a] - side) <= tol;
        if (all) on_face = true;
      }
    if (!on_face) {
      m << "facet (";
      for (int k = 0; k < dim; ++k) m << (k ? ", " : "") << f[k];
      m << ") belongs to one cell but is not on the box boundary (a hole in the mesh)";
      return m.str();
    }
  }
  const double box_volume = (box_max - box_min).prod();
  if (std::abs(static_cast<double>(volume) - box_volume) > 1e-9 * box_volume) {
    m << "the cells' volumes sum to " << static_cast<double>(volume) << ", not the box volume " << box_volume;
    return m.str();
  }
  return {};
}

template std::string mesh_invariant_violation<2>(const SimplexMesh<2>&, const std::vector<char>&,
                                                 const std::vector<std::uint8_t>&, const Eigen::Vector2d&,
                                                 const Eigen::Vector2d&, double, const QualityBound&, double);
template std::string mesh_invariant_violation<3>(const SimplexMesh<3>&, const std::vector<char>&,
                                                 const std::vector<std::uint8_t>&, const Eigen::Vector3d&,
                                                 const Eigen::Vector3d&, double, const QualityBound&, double);

}  // namespace vim

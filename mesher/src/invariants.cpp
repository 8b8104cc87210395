// Mesh invariants (invariants.hpp): a from-scratch check of node placement, cell validity and
// quality, and conformity (facets matched by vim::match_facets) of the live cells of a VIM mesh of
// the image box.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <vim/facets.hpp>
#include <vim/invariants.hpp>
#include <vim/point_text.hpp>

namespace vim {
namespace {

// The first violated node invariant: in the box, on its box faces (fixed_axes). "" if none.
template <int dim>
std::string node_violation(const SimplexMesh<dim>& mesh, const std::vector<std::uint8_t>& fixed_axes,
                           const Eigen::Matrix<double, dim, 1>& box_min,
                           const Eigen::Matrix<double, dim, 1>& box_max, double tol) {
  std::ostringstream m;
  const long n_points = static_cast<long>(mesh.points.size());
  for (long i = 0; i < n_points; ++i) {
    const auto& p = mesh.points[i];
    for (int a = 0; a < dim; ++a) {
      if (!(p[a] >= box_min[a] - tol && p[a] <= box_max[a] + tol)) {
        m << "node " << i << " at " << point_text(p.data(), dim) << " is outside the box along axis " << a
          << " [" << box_min[a] << ", " << box_max[a] << "]";
        return m.str();
      }
      if (!fixed_axes.empty() && (fixed_axes[i] >> a & 1u) && std::abs(p[a] - box_min[a]) > tol &&
          std::abs(p[a] - box_max[a]) > tol) {
        m << "boundary node " << i << " at " << point_text(p.data(), dim) << " left its box face along axis "
          << a;
        return m.str();
      }
    }
  }
  return {};
}

// The first violated invariant of cell c alone: valid distinct vertices, positive volume (added to
// *volume), quality bound. "" if none.
template <int dim>
std::string cell_violation(const SimplexMesh<dim>& mesh, std::size_t c, const QualityBound& bound,
                           double slack_deg, long double* volume) {
  std::ostringstream m;
  const long n_points = static_cast<long>(mesh.points.size());
  auto v = mesh.cells[c];
  for (int k = 0; k <= dim; ++k)
    if (v[k] < 0 || v[k] >= n_points) {
      m << "cell " << c << " has vertex index " << v[k] << " outside [0, " << n_points << ")";
      return m.str();
    }
  std::sort(v.begin(), v.end());
  if (std::adjacent_find(v.begin(), v.end()) != v.end()) {
    m << "cell " << c << " repeats a vertex";
    return m.str();
  }
  const auto x = cell_points(mesh, c);
  const double vol = signed_volume<dim>(x);
  if (!(vol > 0.0)) {
    m << "cell " << c << " is inverted or degenerate (signed volume " << vol << ")";
    return m.str();
  }
  *volume += vol;
  const double amax = max_dihedral_deg<dim>(x), amin = min_dihedral_deg<dim>(x);
  if (!(amax <= bound.max_dihedral_deg + slack_deg)) {
    m << "cell " << c << " breaks the quality bound: max " << (dim == 3 ? "dihedral" : "interior")
      << " angle " << amax << "° > " << bound.max_dihedral_deg << "°";
    return m.str();
  }
  if (bound.min_dihedral_deg > 0.0 && !(amin >= bound.min_dihedral_deg - slack_deg)) {
    m << "cell " << c << " breaks the quality bound: min angle " << amin << "° < " << bound.min_dihedral_deg
      << "°";
    return m.str();
  }
  if (bound.min_radius_ratio > 0.0) {
    const double r = normalized_radius_ratio<dim>(x);
    if (!(r >= bound.min_radius_ratio - 1e-9)) {
      m << "cell " << c << " breaks the quality bound: radius ratio " << r << " < " << bound.min_radius_ratio;
      return m.str();
    }
  }
  return {};
}

// A facet of one cell must lie on one box face: all its vertices on the same side of one axis.
template <int dim>
bool on_box_face(const SimplexMesh<dim>& mesh, const std::array<int, dim>& f,
                 const Eigen::Matrix<double, dim, 1>& box_min, const Eigen::Matrix<double, dim, 1>& box_max,
                 double tol) {
  for (int a = 0; a < dim; ++a)
    for (const double side : {box_min[a], box_max[a]}) {
      bool all = true;
      for (int v : f) all = all && std::abs(mesh.points[v][a] - side) <= tol;
      if (all) return true;
    }
  return false;
}

}  // namespace

template <int dim>
std::string mesh_invariant_violation(const SimplexMesh<dim>& mesh, const std::vector<char>& alive,
                                     const std::vector<std::uint8_t>& fixed_axes,
                                     const Eigen::Matrix<double, dim, 1>& box_min,
                                     const Eigen::Matrix<double, dim, 1>& box_max, double tol,
                                     const QualityBound& bound, double slack_deg) {
  std::string violation = node_violation<dim>(mesh, fixed_axes, box_min, box_max, tol);
  if (!violation.empty()) return violation;
  // Cells in order up to the first one that breaks an invariant on its own (checked_end − 1).
  long double volume = 0.0L;
  std::size_t checked_end = 0;
  for (; checked_end < mesh.cells.size() && violation.empty(); ++checked_end)
    if (alive.empty() || alive[checked_end])
      violation = cell_violation<dim>(mesh, checked_end, bound, slack_deg, &volume);
  // Conformity of the live cells before it. A facet with a third cell is reported at that cell when
  // it comes first: the order of a scan that checks each cell, then its facets.
  std::vector<char> live(mesh.cells.size(), 0);
  for (std::size_t c = 0; c < checked_end; ++c) live[c] = alive.empty() || alive[c];
  if (!violation.empty()) live[checked_end - 1] = 0;
  const FacetIncidence<dim> facets = match_facets<dim>(mesh.points.size(), mesh.cells, live);
  std::size_t overlap = mesh.cells.size();
  for (std::size_t g = 0; g < facets.n_facets(); ++g)
    if (facets.count(g) > 2) overlap = std::min(overlap, facets.use(g, 2).cell());
  std::ostringstream m;
  if (overlap < mesh.cells.size()) {
    m << "facet of cell " << overlap << " is shared by more than two cells (overlapping cells)";
    return m.str();
  }
  if (!violation.empty()) return violation;
  for (std::size_t g = 0; g < facets.n_facets(); ++g) {
    const auto& f = facets.use(g, 0).vertices;
    if (facets.count(g) != 1 || on_box_face<dim>(mesh, f, box_min, box_max, tol)) continue;
    m << "facet (";
    for (int k = 0; k < dim; ++k) m << (k ? ", " : "") << f[k];
    m << ") belongs to one cell but is not on the box boundary (a hole in the mesh)";
    return m.str();
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

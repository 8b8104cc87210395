// Initial mesh (paper §IV-C, §VI): node counts from a budget or spacing, the Kuhn/Freudenthal
// subdivision of a regular grid over the box, and the boundary classification of its nodes.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vim/initial_mesh.hpp>

namespace vim {

namespace {

template <int dim>
void check_box(const Eigen::Matrix<double, dim, 1>& lo, const Eigen::Matrix<double, dim, 1>& hi) {
  for (int a = 0; a < dim; ++a)
    if (!(hi[a] > lo[a]) || !std::isfinite(hi[a] - lo[a]))
      throw std::invalid_argument("box: box_max must exceed box_min on every axis (axis " +
                                  std::to_string(a) + ": [" + std::to_string(lo[a]) + ", " +
                                  std::to_string(hi[a]) + "])");
}

template <int dim>
std::array<int, dim> counts_for_cell_size(const Eigen::Matrix<double, dim, 1>& lo,
                                          const Eigen::Matrix<double, dim, 1>& hi, double h) {
  std::array<int, dim> n;
  for (int a = 0; a < dim; ++a) {
    const double cells = std::round((hi[a] - lo[a]) / h);
    n[a] = static_cast<int>(std::clamp(cells, 1.0, 1e9)) + 1;
  }
  return n;
}

template <int dim>
long product(const std::array<int, dim>& n) {
  long p = 1;
  for (int v : n) p *= v;
  return p;
}

// Node ids are int: a grid of more nodes cannot be indexed (its product, in double, cannot overflow).
template <int dim>
void check_node_count(const std::array<int, dim>& n, const std::string& what) {
  double total = 1.0;
  std::string axes;
  for (int a = 0; a < dim; ++a) {
    total *= n[a];
    axes += (a ? " x " : "") + std::to_string(n[a]);
  }
  if (total > static_cast<double>(std::numeric_limits<int>::max()))
    throw std::invalid_argument(what + " gives a grid of " + axes + " nodes, more than the " +
                                std::to_string(std::numeric_limits<int>::max()) +
                                " a mesh can index; use a larger spacing or fewer nodes");
}

}  // namespace

template <int dim>
std::array<int, dim> nodes_per_axis_for_budget(const Eigen::Matrix<double, dim, 1>& box_min,
                                               const Eigen::Matrix<double, dim, 1>& box_max,
                                               long node_budget) {
  const long minimum = 1L << dim;
  if (node_budget < minimum)
    throw std::invalid_argument("nodes: node budget " + std::to_string(node_budget) +
                                " is below the minimum " + std::to_string(minimum) +
                                " (2 nodes per axis in " + std::to_string(dim) + "D)");
  check_box<dim>(box_min, box_max);
  const Eigen::Matrix<double, dim, 1> len = box_max - box_min;
  const double longest = len.maxCoeff();
  // Cell size h = longest / m for m = 1, 2, ...: the node count is non-decreasing in m;
  // keep the last one ≤ budget.
  std::array<int, dim> best;
  best.fill(2);
  for (long m = 1; m + 1 <= node_budget; ++m) {
    const auto n = counts_for_cell_size<dim>(box_min, box_max, longest / static_cast<double>(m));
    const long p = product<dim>(n);
    if (p > node_budget) break;  // the count is non-decreasing in m
    best = n;
  }
  return best;
}

template <int dim>
std::array<int, dim> nodes_per_axis_for_spacing(const Eigen::Matrix<double, dim, 1>& box_min,
                                                const Eigen::Matrix<double, dim, 1>& box_max,
                                                double spacing) {
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw std::invalid_argument("spacing: node spacing must be a finite value > 0 (got " +
                                std::to_string(spacing) + ")");
  check_box<dim>(box_min, box_max);
  const auto n = counts_for_cell_size<dim>(box_min, box_max, spacing);
  std::ostringstream what;
  what << "spacing: node spacing " << spacing;
  check_node_count<dim>(n, what.str());
  return n;
}

template <int dim>
SimplexMesh<dim> regular_grid_mesh(const Eigen::Matrix<double, dim, 1>& box_min,
                                   const Eigen::Matrix<double, dim, 1>& box_max,
                                   const std::array<int, dim>& n) {
  check_box<dim>(box_min, box_max);
  for (int a = 0; a < dim; ++a)
    if (n[a] < 2)
      throw std::invalid_argument("nodes_per_axis: every axis needs >= 2 nodes (axis " + std::to_string(a) +
                                  " has " + std::to_string(n[a]) + ")");
  check_node_count<dim>(n, "nodes_per_axis");
  SimplexMesh<dim> mesh;
  const long total = product<dim>(n);
  mesh.points.reserve(static_cast<std::size_t>(total));
  std::array<long, dim> stride;
  stride[0] = 1;
  for (int a = 1; a < dim; ++a) stride[a] = stride[a - 1] * n[a - 1];
  for (long k = 0; k < total; ++k) {
    typename SimplexMesh<dim>::Point p;
    long r = k;
    for (int a = 0; a < dim; ++a) {
      const long i = r % n[a];
      r /= n[a];
      // Exact end points; interior nodes by linear interpolation.
      p[a] = i == n[a] - 1 ? box_max[a]
                           : box_min[a] + (box_max[a] - box_min[a]) * static_cast<double>(i) / (n[a] - 1);
    }
    mesh.points.push_back(p);
  }
  // Kuhn subdivision: for each permutation π of the axes, the path 0 → e_π0 → e_π0+e_π1 → ... → 1.
  std::array<int, dim> perm;
  std::iota(perm.begin(), perm.end(), 0);
  std::vector<std::array<int, dim>> perms;
  do perms.push_back(perm);
  while (std::next_permutation(perm.begin(), perm.end()));
  long cells = 1;
  for (int a = 0; a < dim; ++a) cells *= n[a] - 1;
  mesh.cells.reserve(static_cast<std::size_t>(cells) * perms.size());
  for (long c = 0; c < cells; ++c) {
    long r = c, base = 0;
    for (int a = 0; a < dim; ++a) {
      base += (r % (n[a] - 1)) * stride[a];
      r /= n[a] - 1;
    }
    for (const auto& pi : perms) {
      typename SimplexMesh<dim>::Cell cell;
      long v = base;
      cell[0] = static_cast<int>(v);
      for (int k = 0; k < dim; ++k) {
        v += stride[pi[k]];
        cell[k + 1] = static_cast<int>(v);
      }
      mesh.cells.push_back(cell);
    }
  }
  orient_positively(mesh);
  return mesh;
}

template <int dim>
std::vector<std::uint8_t> boundary_kind(const SimplexMesh<dim>& mesh,
                                        const Eigen::Matrix<double, dim, 1>& box_min,
                                        const Eigen::Matrix<double, dim, 1>& box_max, double tol) {
  std::vector<std::uint8_t> kind(mesh.n_points(), 0);
  for (std::size_t i = 0; i < mesh.n_points(); ++i) {
    int k = 0;
    for (int a = 0; a < dim; ++a)
      if (std::abs(mesh.points[i][a] - box_min[a]) <= tol || std::abs(mesh.points[i][a] - box_max[a]) <= tol)
        ++k;
    kind[i] = static_cast<std::uint8_t>(k);
  }
  return kind;
}

#define VIM_INITIAL_MESH_INSTANTIATE(D)                                                                   \
  template std::array<int, D> nodes_per_axis_for_budget<D>(const Eigen::Matrix<double, D, 1>&,            \
                                                           const Eigen::Matrix<double, D, 1>&, long);     \
  template std::array<int, D> nodes_per_axis_for_spacing<D>(const Eigen::Matrix<double, D, 1>&,           \
                                                            const Eigen::Matrix<double, D, 1>&, double);  \
  template SimplexMesh<D> regular_grid_mesh<D>(                                                           \
      const Eigen::Matrix<double, D, 1>&, const Eigen::Matrix<double, D, 1>&, const std::array<int, D>&); \
  template std::vector<std::uint8_t> boundary_kind<D>(const SimplexMesh<D>&,                              \
                                                      const Eigen::Matrix<double, D, 1>&,                 \
                                                      const Eigen::Matrix<double, D, 1>&, double);
VIM_INITIAL_MESH_INSTANTIATE(2)
VIM_INITIAL_MESH_INSTANTIATE(3)
#undef VIM_INITIAL_MESH_INSTANTIATE

}  // namespace vim

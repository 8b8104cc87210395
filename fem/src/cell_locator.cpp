// Point location in simplex meshes (buckets of about one cell each, barycentric test) and in regular
// grids (index arithmetic); see cell_locator.hpp.
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vim/fem/cell_locator.hpp>

namespace vim::fem {

template <int dim>
CellLocator<dim> CellLocator<dim>::simplex(const SimplexMesh<dim>& mesh) {
  CellLocator loc;
  loc.simplices_ = mesh.cells;
  const std::size_t nc = mesh.n_cells();
  if (nc == 0) throw std::invalid_argument("CellLocator: empty mesh");
  loc.inverse_.resize(nc);
  loc.lo_ = Vec::Constant(std::numeric_limits<double>::max());
  loc.hi_ = -loc.lo_;
  double edge_sum = 0.0;
  std::size_t edges = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    const auto x = cell_points(mesh, c);
    Eigen::Matrix<double, dim, dim> m;
    for (int k = 0; k < dim; ++k) m.col(k) = x[k + 1] - x[0];
    loc.inverse_[c] = m.inverse();
    for (int a = 0; a <= dim; ++a) {
      loc.lo_ = loc.lo_.cwiseMin(x[a]);
      loc.hi_ = loc.hi_.cwiseMax(x[a]);
      for (int b = a + 1; b <= dim; ++b, ++edges) edge_sum += (x[a] - x[b]).norm();
    }
  }
  loc.mean_edge_ = edge_sum / static_cast<double>(edges);
  loc.vertices_ = mesh.points;
  // Buckets: about one cell per bucket on average.
  const Vec ext = (loc.hi_ - loc.lo_).cwiseMax(Vec::Constant(1e-12));
  const double cell = std::pow(ext.prod() / static_cast<double>(nc), 1.0 / dim);
  std::size_t nbuckets = 1;
  for (int d = 0; d < dim; ++d) {
    loc.nb_[d] = std::max(1L, std::min(256L, static_cast<long>(std::ceil(ext[d] / cell))));
    loc.bucket_size_[d] = ext[d] / static_cast<double>(loc.nb_[d]);
    nbuckets *= static_cast<std::size_t>(loc.nb_[d]);
  }
  loc.buckets_.assign(nbuckets, {});
  for (std::size_t c = 0; c < nc; ++c) {
    const auto x = cell_points(mesh, c);
    Vec a = x[0], b = x[0];
    for (int k = 1; k <= dim; ++k) {
      a = a.cwiseMin(x[k]);
      b = b.cwiseMax(x[k]);
    }
    std::array<long, dim> i0{}, i1{};
    for (int d = 0; d < dim; ++d) {
      i0[d] = std::clamp(static_cast<long>(std::floor((a[d] - loc.lo_[d]) / loc.bucket_size_[d] - 1e-9)), 0L,
                         loc.nb_[d] - 1);
      i1[d] = std::clamp(static_cast<long>(std::floor((b[d] - loc.lo_[d]) / loc.bucket_size_[d] + 1e-9)), 0L,
                         loc.nb_[d] - 1);
    }
    std::array<long, dim> i = i0;
    while (true) {
      std::size_t k = 0;
      for (int d = dim - 1; d >= 0; --d)
        k = k * static_cast<std::size_t>(loc.nb_[d]) + static_cast<std::size_t>(i[d]);
      loc.buckets_[k].push_back(static_cast<int>(c));
      int d = 0;
      for (; d < dim; ++d) {
        if (++i[d] <= i1[d]) break;
        i[d] = i0[d];
      }
      if (d == dim) break;
    }
  }
  return loc;
}

template <int dim>
CellLocator<dim> CellLocator<dim>::grid(const std::array<long, dim>& cells, const Vec& lo, const Vec& hi,
                                        const std::vector<Vec>& vertices) {
  CellLocator loc;
  loc.is_grid_ = true;
  loc.cells_ = cells;
  loc.lo_ = lo;
  loc.hi_ = hi;
  std::size_t nlat = 1;
  double edge = 0.0;
  for (int d = 0; d < dim; ++d) {
    if (cells[d] < 1) throw std::invalid_argument("CellLocator::grid: every axis needs >= 1 cell");
    loc.bucket_size_[d] = (hi[d] - lo[d]) / static_cast<double>(cells[d]);
    nlat *= static_cast<std::size_t>(cells[d] + 1);
    edge += loc.bucket_size_[d];
  }
  loc.mean_edge_ = edge / dim;
  loc.lattice_to_vertex_.assign(nlat, -1);
  loc.vertices_ = vertices;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    std::size_t k = 0;
    bool ok = true;
    for (int d = dim - 1; d >= 0; --d) {
      const double t = (vertices[v][d] - lo[d]) / loc.bucket_size_[d];
      const long i = std::lround(t);
      if (std::abs(t - static_cast<double>(i)) > 1e-6 || i < 0 || i > cells[d]) ok = false;
      k = k * static_cast<std::size_t>(cells[d] + 1) + static_cast<std::size_t>(std::clamp(i, 0L, cells[d]));
    }
    if (ok) loc.lattice_to_vertex_[k] = static_cast<int>(v);
  }
  if (std::find(loc.lattice_to_vertex_.begin(), loc.lattice_to_vertex_.end(), -1) !=
      loc.lattice_to_vertex_.end())
    throw std::invalid_argument("CellLocator::grid: the model's vertices do not cover the lattice");
  return loc;
}

template <int dim>
long CellLocator<dim>::locate(const Vec& p, std::vector<int>* support) const {
  if (support) support->clear();
  return is_grid_ ? locate_in_grid(p, support) : locate_in_simplices(p, support);
}

namespace {
constexpr double kBarycentricTolerance = 1e-10;  // a point this far outside a simplex still lies in it
constexpr double kSupportWeight = 1e-9;          // shape functions above this weight form the support
}  // namespace

template <int dim>
long CellLocator<dim>::locate_in_grid(const Vec& p, std::vector<int>* support) const {
  std::array<long, dim> i{};
  std::array<double, dim> t{};
  for (int d = 0; d < dim; ++d) {
    const double c = (p[d] - lo_[d]) / bucket_size_[d];
    if (c < -1e-9 || c > static_cast<double>(cells_[d]) + 1e-9) return -1;
    i[d] = std::clamp(static_cast<long>(std::floor(c)), 0L, cells_[d] - 1);
    t[d] = std::clamp(c - static_cast<double>(i[d]), 0.0, 1.0);
  }
  long cell = 0;
  for (int d = dim - 1; d >= 0; --d) cell = cell * cells_[d] + i[d];
  if (!support) return cell;
  for (int corner = 0; corner < (1 << dim); ++corner) {
    double w = 1.0;
    std::size_t k = 0;
    for (int d = dim - 1; d >= 0; --d) {
      const bool up = (corner >> d) & 1;
      w *= up ? t[d] : 1.0 - t[d];
      k = k * static_cast<std::size_t>(cells_[d] + 1) + static_cast<std::size_t>(i[d] + (up ? 1 : 0));
    }
    if (w > kSupportWeight) support->push_back(lattice_to_vertex_[k]);
  }
  std::sort(support->begin(), support->end());
  return cell;
}

template <int dim>
long CellLocator<dim>::locate_in_simplices(const Vec& p, std::vector<int>* support) const {
  std::size_t k = 0;
  for (int d = dim - 1; d >= 0; --d) {
    const double c = (p[d] - lo_[d]) / bucket_size_[d];
    if (c < -1e-9 * nb_[d] || c > static_cast<double>(nb_[d]) * (1.0 + 1e-9)) return -1;
    k = k * static_cast<std::size_t>(nb_[d]) +
        static_cast<std::size_t>(std::clamp(static_cast<long>(std::floor(c)), 0L, nb_[d] - 1));
  }
  for (int c : buckets_[k]) {
    const auto& cell = simplices_[static_cast<std::size_t>(c)];
    const Vec l = inverse_[static_cast<std::size_t>(c)] * (p - vertices_[static_cast<std::size_t>(cell[0])]);
    const double l0 = 1.0 - l.sum();
    if (l0 < -kBarycentricTolerance || l.minCoeff() < -kBarycentricTolerance) continue;
    if (support) {
      if (l0 > kSupportWeight) support->push_back(cell[0]);
      for (int a = 0; a < dim; ++a)
        if (l[a] > kSupportWeight) support->push_back(cell[a + 1]);
      std::sort(support->begin(), support->end());
    }
    return c;
  }
  return -1;
}

template class CellLocator<2>;
template class CellLocator<3>;

}  // namespace vim::fem

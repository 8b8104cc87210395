// Checks of the input of an elastic model (see input_checks.hpp). Plain C++ and Eigen.
#include "input_checks.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/facets.hpp>

namespace vim::fem {

void check_poisson_ratio(double nu) {
  if (!(nu > -1.0 && nu < 0.5)) {
    std::ostringstream m;
    m << "Poisson ratio " << nu << " is outside (-1, 0.5)";
    throw std::invalid_argument(m.str());
  }
}

void check_moduli(const std::vector<double>& E, std::size_t n_cells, const char* what) {
  if (E.size() != n_cells) {
    std::ostringstream m;
    m << what << ": " << E.size() << " Young's moduli given for " << n_cells << " cells";
    throw std::invalid_argument(m.str());
  }
  for (std::size_t j = 0; j < E.size(); ++j)
    if (!std::isfinite(E[j]) || !(E[j] > 0.0)) {
      std::ostringstream m;
      m << what << ": Young's modulus of cell " << j << " is " << E[j] << "; it must be finite and > 0";
      throw std::invalid_argument(m.str());
    }
}

template <int dim>
void check_voxel_grid(const std::array<long, dim>& cells, const Vec<dim>& box_min, const Vec<dim>& box_max) {
  for (int d = 0; d < dim; ++d) {
    if (cells[d] < 1) {
      std::ostringstream m;
      m << "voxel_grid: " << cells[d] << " cells along axis " << d << "; need >= 1";
      throw std::invalid_argument(m.str());
    }
    if (!std::isfinite(box_min[d]) || !std::isfinite(box_max[d]) || !(box_max[d] > box_min[d])) {
      std::ostringstream m;
      m << "voxel_grid: box [" << box_min[d] << ", " << box_max[d] << "] along axis " << d
        << " is empty or not finite";
      throw std::invalid_argument(m.str());
    }
  }
}

namespace {

template <int dim>
void check_vertices_and_volumes(const SimplexMesh<dim>& mesh) {
  if (mesh.cells.empty()) throw std::invalid_argument("ElasticModel: the mesh has no cells");
  const int np = static_cast<int>(mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    if (!mesh.points[i].allFinite())
      throw std::invalid_argument("ElasticModel: mesh vertex " + std::to_string(i) +
                                  " has a non-finite coordinate");
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    for (int k = 0; k <= dim; ++k)
      if (mesh.cells[c][k] < 0 || mesh.cells[c][k] >= np) {
        std::ostringstream m;
        m << "ElasticModel: cell " << c << " refers to vertex " << mesh.cells[c][k] << "; valid are 0.."
          << np - 1;
        throw std::invalid_argument(m.str());
      }
    const auto x = cell_points(mesh, c);
    double h = 0.0;
    for (int a = 0; a <= dim; ++a)
      for (int b = a + 1; b <= dim; ++b) h = std::max(h, (x[a] - x[b]).norm());
    const double vol = signed_volume<dim>(x);
    if (!(std::abs(vol) > 1e-10 * std::pow(h, dim))) {
      std::ostringstream m;
      m << "ElasticModel: cell " << c << " is degenerate (volume " << vol << ", longest edge " << h << ")";
      throw std::invalid_argument(m.str());
    }
  }
}

}  // namespace

namespace {
// In-place sum over `comm`; a program that has not initialised MPI is one process (nothing to sum).
void sum_over(MPI_Comm comm, void* data, int n, MPI_Datatype type) {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (initialized && !finalized) MPI_Allreduce(MPI_IN_PLACE, data, n, type, MPI_SUM, comm);
}

template <int dim>
std::string no_constrained_node_message(const std::vector<DirichletBC<dim>>& bcs) {
  std::ostringstream m;
  m << "no Dirichlet condition constrains any node (";
  if (bcs.empty()) {
    m << "none was added";
  } else {
    m << "regions:";
    for (const auto& bc : bcs) m << " '" << bc.region.name << "'";
    m << " select no node";
  }
  m << "): the stiffness matrix is singular; fix part of the boundary";
  return m.str();
}
}  // namespace

// The conditions remove every rigid motion iff no rigid mode r ≠ 0 vanishes on all constrained
// DoFs, i.e. the Gram matrix Σ_i r_k(i) r_l(i) over constrained DoFs is non-singular.
template <int dim>
void check_rigid_modes_removed(const ConstrainedDirections<dim>& constrained,
                               const std::vector<Vec<dim>>& vertices,
                               const std::vector<DirichletBC<dim>>& bcs, MPI_Comm comm) {
  unsigned long long n_constrained = constrained.size();
  sum_over(comm, &n_constrained, 1, MPI_UNSIGNED_LONG_LONG);
  if (n_constrained == 0) throw std::runtime_error(no_constrained_node_message(bcs));
  constexpr int nm = dim == 2 ? 3 : 6;
  // rotations about the bounding-box centre, scaled to unit size (the same on every rank)
  Vec<dim> lo = vertices[0], hi = vertices[0];
  for (const auto& v : vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const Vec<dim> c0 = 0.5 * (lo + hi);
  const double scale = std::max(0.5 * (hi - lo).norm(), std::numeric_limits<double>::min());
  Eigen::Matrix<double, nm, nm> G = Eigen::Matrix<double, nm, nm>::Zero();
  for (const auto& [x, n] : constrained) {
    // The constrained direction n seen by each rigid mode: translations n, rotations ω·(r × n).
    const Vec<dim> r = (x - c0) / scale;
    Eigen::Matrix<double, nm, 1> row = Eigen::Matrix<double, nm, 1>::Zero();
    for (int d = 0; d < dim; ++d) row[d] = n[d];
    if constexpr (dim == 2) {
      row[2] = -r[1] * n[0] + r[0] * n[1];
    } else {
      const Vec<3> rn = r.cross(n);
      for (int a = 0; a < 3; ++a) row[3 + a] = rn[a];
    }
    G += row * row.transpose();
  }
  sum_over(comm, G.data(), nm * nm, MPI_DOUBLE);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, nm, nm>> es(G);
  if (!(es.eigenvalues()[0] > 1e-10 * std::max(1.0, es.eigenvalues()[nm - 1]))) {
    std::ostringstream m;
    m << "the Dirichlet conditions constrain " << n_constrained
      << " DoFs but leave a rigid-body motion free (e.g. only one component or one line fixed): "
         "the stiffness matrix is singular; constrain enough components/nodes";
    throw SingularConstraints(m.str());
  }
}

// Facets (sorted vertex ids) bucketed by their smallest vertex (counting sort, linear, instead of a hash
// map of all facets); equal facets are found by sorting each small bucket.
// The error reported is the first offending (cell, facet) in cell order, as in a sequential scan: the
// second cell on a facet whose opposite vertices lie on the same side (inverted), or the third cell on a
// facet (non-manifold).
template <int dim>
void check_simplex_mesh(const SimplexMesh<dim>& mesh) {
  check_vertices_and_volumes(mesh);
  // Side of the opposite vertex of the facet at `pos`, against the facet's sorted vertices.
  const auto side = [&mesh](std::size_t pos) {
    const auto& cell = mesh.cells[pos / (dim + 1)];
    const int k = static_cast<int>(pos % (dim + 1));
    const std::array<int, dim> v = sorted_facet<dim>(cell, k);
    std::array<Eigen::Matrix<double, dim, 1>, dim + 1> x;
    for (int i = 0; i < dim; ++i) x[i] = mesh.points[v[i]];
    x[dim] = mesh.points[cell[k]];
    return signed_volume<dim>(x) > 0.0 ? 1 : -1;
  };
  const std::size_t none = std::numeric_limits<std::size_t>::max();
  std::size_t bad = none, bad_first = 0;
  bool bad_inverted = false;
  const FacetIncidence<dim> facets = match_facets<dim>(mesh.points.size(), mesh.cells);
  for (std::size_t g = 0; g < facets.n_facets(); ++g) {
    const std::size_t n = facets.count(g);
    const auto pos = [&](std::size_t i) { return facets.use(g, i).position; };
    if (n >= 2 && side(pos(1)) == side(pos(0))) {
      if (pos(1) < bad) bad = pos(1), bad_first = pos(0), bad_inverted = true;
    } else if (n >= 3 && pos(2) < bad) {
      bad = pos(2), bad_inverted = false;
    }
  }
  if (bad == none) return;
  const std::size_t c = bad / (dim + 1);
  if (!bad_inverted)
    throw std::invalid_argument("ElasticModel: cell " + std::to_string(c) +
                                " shares a face with two other cells (non-manifold mesh)");
  std::ostringstream m;
  m << "ElasticModel: cell " << c << " is inverted: it overlaps cell " << bad_first / (dim + 1)
    << " across their shared face (tangled mesh)";
  throw std::invalid_argument(m.str());
}

template <int dim>
void check_support_base(const std::vector<Vec<dim>>& base, std::size_t n_points, const std::string& where) {
  if (!base.empty() && base.size() != n_points)
    throw std::invalid_argument(where + ": " + std::to_string(base.size()) + " base displacements for " +
                                std::to_string(n_points) + " points (give one per point, or none)");
  for (std::size_t i = 0; i < base.size(); ++i)
    if (!base[i].allFinite())
      throw std::invalid_argument(where + ": the base displacement of point " + std::to_string(i) +
                                  " is not finite");
}

template void check_support_base<2>(const std::vector<Vec<2>>&, std::size_t, const std::string&);
template void check_support_base<3>(const std::vector<Vec<3>>&, std::size_t, const std::string&);
template void check_voxel_grid<2>(const std::array<long, 2>&, const Vec<2>&, const Vec<2>&);
template void check_voxel_grid<3>(const std::array<long, 3>&, const Vec<3>&, const Vec<3>&);
template void check_rigid_modes_removed<2>(const ConstrainedDirections<2>&, const std::vector<Vec<2>>&,
                                           const std::vector<DirichletBC<2>>&, MPI_Comm);
template void check_rigid_modes_removed<3>(const ConstrainedDirections<3>&, const std::vector<Vec<3>>&,
                                           const std::vector<DirichletBC<3>>&, MPI_Comm);
template void check_simplex_mesh<2>(const SimplexMesh<2>&);
template void check_simplex_mesh<3>(const SimplexMesh<3>&);

}  // namespace vim::fem

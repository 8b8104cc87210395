// SimplexMesh<dim>: triangles (dim = 2) or tetrahedra (dim = 3) as plain arrays, plus the
// small geometric helpers (signed volume, orientation, centroid) every module uses.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <vector>

namespace vim {

template <int dim>
struct SimplexMesh {
  using Point = Eigen::Matrix<double, dim, 1>;
  using Cell = std::array<int, dim + 1>;

  std::vector<Point> points;
  std::vector<Cell> cells;

  std::size_t n_points() const { return points.size(); }
  std::size_t n_cells() const { return cells.size(); }
};

inline constexpr double factorial(int n) { return n <= 1 ? 1.0 : n * factorial(n - 1); }

// Signed measure of the simplex (x_0..x_dim): det[x_1-x_0, ..., x_dim-x_0] / dim!.
// Positive for counter-clockwise triangles and right-handed tetrahedra.
template <int dim>
double signed_volume(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  Eigen::Matrix<double, dim, dim> m;
  for (int k = 0; k < dim; ++k) m.col(k) = x[k + 1] - x[0];
  return m.determinant() / factorial(dim);
}

template <int dim>
std::array<Eigen::Matrix<double, dim, 1>, dim + 1> cell_points(const SimplexMesh<dim>& mesh, std::size_t c) {
  std::array<Eigen::Matrix<double, dim, 1>, dim + 1> x;
  for (int k = 0; k <= dim; ++k) x[k] = mesh.points[mesh.cells[c][k]];
  return x;
}

template <int dim>
double signed_volume(const SimplexMesh<dim>& mesh, std::size_t c) {
  return signed_volume<dim>(cell_points(mesh, c));
}

template <int dim>
Eigen::Matrix<double, dim, 1> centroid(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x) {
  Eigen::Matrix<double, dim, 1> c = Eigen::Matrix<double, dim, 1>::Zero();
  for (const auto& p : x) c += p;
  return c / static_cast<double>(dim + 1);
}

// Reorders every negatively oriented cell (swaps its first two vertices) so all volumes are > 0.
// Returns the number of cells that were flipped.
template <int dim>
std::size_t orient_positively(SimplexMesh<dim>& mesh) {
  std::size_t flipped = 0;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c)
    if (signed_volume(mesh, c) < 0.0) {
      std::swap(mesh.cells[c][0], mesh.cells[c][1]);
      ++flipped;
    }
  return flipped;
}

template <int dim>
double total_volume(const SimplexMesh<dim>& mesh) {
  double v = 0.0;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) v += std::abs(signed_volume(mesh, c));
  return v;
}

}  // namespace vim

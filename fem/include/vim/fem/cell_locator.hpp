// The project's point locator: the cell of a simplex mesh or of a regular grid of cells that contains
// a point. ElasticModel locates its point constraints, sample points and volume-support points with it;
// the needle simulation samples the shaft with it. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>
#include <vim/simplex_mesh.hpp>

namespace vim::fem {

// Point location in a simplex mesh or in a regular grid of cells. locate() returns the cell containing p
// (-1 outside; on a shared face the lowest cell index, within 1e-10 in barycentric coordinates for
// simplices and 1e-9 cell widths on the grid) and, optionally, the vertices whose P1/Q1 shape functions
// are non-zero at p (the support of an embedded-point constraint there). Simplex cells are numbered as
// in the mesh; grid cells lexicographically, axis 0 fastest.
template <int dim>
class CellLocator {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  static CellLocator simplex(const SimplexMesh<dim>& mesh);
  // Grid of cells[0]×…×cells[dim-1] cells on [lo, hi]; `vertices` are the model's vertices in its own
  // numbering (every lattice point must be one of them).
  static CellLocator grid(const std::array<long, dim>& cells, const Vec& lo, const Vec& hi,
                          const std::vector<Vec>& vertices);

  long locate(const Vec& p, std::vector<int>* support = nullptr) const;
  // Mean edge length of the cells (a length scale for the shaft sampling).
  double mean_edge_length() const { return mean_edge_; }
  // Position of vertex v (the numbering of the supports).
  const Vec& vertex(int v) const { return vertices_[static_cast<std::size_t>(v)]; }

 private:
  long locate_in_grid(const Vec& p, std::vector<int>* support) const;
  long locate_in_simplices(const Vec& p, std::vector<int>* support) const;

  bool is_grid_ = false;
  std::vector<typename SimplexMesh<dim>::Cell> simplices_;  // own copy of the cells (points: vertices_)
  std::vector<Eigen::Matrix<double, dim, dim>> inverse_;    // per simplex: maps x - x0 to barycentrics 1..dim
  Vec lo_, hi_, bucket_size_;
  std::array<long, dim> nb_{};
  std::vector<std::vector<int>> buckets_;
  std::array<long, dim> cells_{};
  std::vector<int> lattice_to_vertex_;
  std::vector<Vec> vertices_;
  double mean_edge_ = 0.0;
};

}  // namespace vim::fem

// Brute-force owner of every voxel centre (tests only; no mesher code): for each cell in cell order,
// every voxel of its bounding box (in continuous index space, grown by `margin` voxels) is tested by
// barycentric coordinates; the first cell that holds a centre owns it (-1: none). The tie rule is the
// caller's: `probe(j)` gives the point tested for voxel j (continuous index space; the centre itself, or
// the centre nudged off shared faces) and `inside(b)` decides on its barycentric coordinates b (the
// first omitted: 1 − Σ b).
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

namespace vim::test {

template <int dim, class Probe, class Inside>
std::vector<int> voxel_owner(const Image<dim>& img, const SimplexMesh<dim>& mesh, long margin, Probe probe,
                             Inside inside) {
  using Vec = Eigen::Matrix<double, dim, 1>;
  std::vector<int> owner(img.voxel_count(), -1);
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    std::array<Vec, dim + 1> x;
    Vec lo, hi;
    for (int k = 0; k <= dim; ++k) {
      x[k] = img.continuous_index(mesh.points[static_cast<std::size_t>(mesh.cells[c][k])]);
      lo = k ? lo.cwiseMin(x[k]) : x[k];
      hi = k ? hi.cwiseMax(x[k]) : x[k];
    }
    Eigen::Matrix<double, dim, dim> t;
    for (int a = 0; a < dim; ++a) t.col(a) = x[a + 1] - x[0];
    const Eigen::Matrix<double, dim, dim> ti = t.inverse();
    typename Image<dim>::Index i0, i1;
    bool empty = false;
    for (int a = 0; a < dim; ++a) {
      i0[a] = std::max(0L, static_cast<long>(std::floor(lo[a])) - margin);
      i1[a] = std::min(img.size[a] - 1, static_cast<long>(std::ceil(hi[a])) + margin);
      empty = empty || i0[a] > i1[a];
    }
    if (empty) continue;
    typename Image<dim>::Index j = i0;
    while (true) {
      if (inside(Vec(ti * (probe(j) - x[0])))) {
        int& o = owner[img.linear_index(j)];
        if (o < 0) o = static_cast<int>(c);
      }
      int a = 0;
      while (a < dim && ++j[a] > i1[a]) {
        j[a] = i0[a];
        ++a;
      }
      if (a == dim) break;
    }
  }
  return owner;
}

}  // namespace vim::test

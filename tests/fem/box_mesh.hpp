// Test/benchmark helper: a conforming Kuhn (Freudenthal) simplex mesh of a box with given node
// coordinates per axis (so material interfaces can sit on a node plane). dim! simplices per box.
#pragma once

#include <vim/simplex_mesh.hpp>

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

namespace vim::test {

template <int dim>
SimplexMesh<dim> kuhn_mesh(const std::array<std::vector<double>, dim>& coords) {
  SimplexMesh<dim> mesh;
  std::array<long, dim> n;
  long total = 1;
  for (int d = 0; d < dim; ++d) n[d] = static_cast<long>(coords[d].size()), total *= n[d];
  auto node = [&](const std::array<long, dim>& i) {
    long idx = 0, stride = 1;
    for (int d = 0; d < dim; ++d) idx += i[d] * stride, stride *= n[d];
    return static_cast<int>(idx);
  };
  mesh.points.resize(total);
  for (long k = 0; k < total; ++k) {
    long r = k;
    for (int d = 0; d < dim; ++d) mesh.points[k][d] = coords[d][r % n[d]], r /= n[d];
  }
  std::array<int, dim> perm;
  long cells = 1;
  for (int d = 0; d < dim; ++d) cells *= n[d] - 1;
  for (long k = 0; k < cells; ++k) {
    std::array<long, dim> base;
    long r = k;
    for (int d = 0; d < dim; ++d) base[d] = r % (n[d] - 1), r /= (n[d] - 1);
    std::iota(perm.begin(), perm.end(), 0);
    do {
      typename SimplexMesh<dim>::Cell c;
      std::array<long, dim> i = base;
      c[0] = node(i);
      for (int s = 0; s < dim; ++s) {
        ++i[perm[s]];
        c[s + 1] = node(i);
      }
      mesh.cells.push_back(c);
    } while (std::next_permutation(perm.begin(), perm.end()));
  }
  return mesh;
}

inline std::vector<double> linspace(double a, double b, int cells) {
  std::vector<double> v(cells + 1);
  for (int i = 0; i <= cells; ++i) v[i] = a + (b - a) * i / cells;
  return v;
}

template <int dim>
SimplexMesh<dim> kuhn_box(const std::array<int, dim>& cells, const std::array<double, dim>& lo,
                          const std::array<double, dim>& hi) {
  std::array<std::vector<double>, dim> c;
  for (int d = 0; d < dim; ++d) c[d] = linspace(lo[d], hi[d], cells[d]);
  return kuhn_mesh<dim>(c);
}

}  // namespace vim::test

// A test needle's rows in the unit block, from the top down: row j at height 0.9 − pitch·j and
// x = x0 + shift·j (the others at 0.5); odd rows are bands (the mean over four samples around the axis,
// weights 1.0 … 1.3, held through a compliance of 0.02, as a finite-radius needle's stations), even
// rows points.
#pragma once

#include <vector>
#include <vim/fem/point_constraints.hpp>

namespace vim::test {

template <int dim>
std::vector<fem::PointConstraint<dim>> needle_path_rows(int rows, double pitch, double x0, double shift) {
  using V = fem::Vec<dim>;
  std::vector<fem::PointConstraint<dim>> path;
  for (int j = 0; j < rows; ++j) {
    fem::PointConstraint<dim> p;
    p.position = V::Constant(0.5);
    p.position[dim - 1] = 0.9 - pitch * j;
    p.position[0] = x0 + shift * j;
    if (j % 2 == 1) {
      for (int q = 0; q < 4; ++q) {
        V o = V::Zero();
        o[q % (dim - 1)] = (q < 2 ? 0.04 : -0.04);
        p.offsets.push_back(o);
        p.weights.push_back(1.0 + 0.1 * q);
      }
      p.compliance = V::Constant(0.02);
    }
    path.push_back(p);
  }
  return path;
}

}  // namespace vim::test

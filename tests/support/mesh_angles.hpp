// Independent angle check for meshes written by the CLI (tests only): the smallest dihedral angle
// (3D) or interior angle (2D) over the cells of a VTK grid, from the point coordinates alone.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vtkUnstructuredGrid.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace vim::test {

// Smallest dihedral angle (3D; degrees) or interior angle (2D) over the cells of a mesh.vtu, from
// the point coordinates: in 3D the angle along edge (i, j) is the one between the normals of the
// faces (i, j, k) and (i, j, l); in 2D the angle at each corner between its two edges.
inline double smallest_angle_deg(vtkUnstructuredGrid* g, int dim) {
  double smallest = 180.0;
  for (vtkIdType c = 0; c < g->GetNumberOfCells(); ++c) {
    vtkIdType n = 0;
    const vtkIdType* ids = nullptr;
    g->GetCellPoints(c, n, ids);
    std::vector<Eigen::Vector3d> p(static_cast<std::size_t>(n));
    for (vtkIdType i = 0; i < n; ++i) g->GetPoint(ids[i], p[static_cast<std::size_t>(i)].data());
    auto angle = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180.0 / M_PI;
    };
    if (dim == 3) {
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
          int k = 0;
          while (k == i || k == j) ++k;
          const int l = 6 - i - j - k;
          const Eigen::Vector3d e = p[j] - p[i];
          smallest = std::min(smallest, angle(e.cross(p[k] - p[i]), e.cross(p[l] - p[i])));
        }
    } else {
      for (int i = 0; i < 3; ++i)
        smallest = std::min(smallest, angle(p[(i + 1) % 3] - p[i], p[(i + 2) % 3] - p[i]));
    }
  }
  return smallest;
}

}  // namespace vim::test

// Scanline helpers of the voxel enclosure (paper Eq. 4–6, voxel_statistics.cpp): integer
// floor/ceil without libm, and the rows of one 3D slab that a simplex can cover.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace vim::detail {

// floor/ceil/nearest without a libm call (|t| < 2^62 here: callers clamp to the row range first).
inline long floor_long(double t) {
  const long i = static_cast<long>(t);
  return static_cast<double>(i) > t ? i - 1 : i;
}
inline long ceil_long(double t) {
  const long i = static_cast<long>(t);
  return static_cast<double>(i) < t ? i + 1 : i;
}

// The rows of one slab j_2 (3D) that can hold voxel centres of a simplex: those within the
// cross-section's extent along axis 1. The edges are intersected with the plane x_2 = j_2; with the
// vertices ordered by x_2, a plane strictly between the m-th and (m+1)-th vertex (by more than the
// margin) cuts exactly the edges from vertices 0..m to vertices m+1..3; other planes take the
// general edge-by-edge test.
struct SlabCut {
  std::array<int, 4> o = {0, 1, 2, 3};  // vertices by increasing x_2
  std::array<double, 4> zv, yv;         // their x_2 and x_1
  std::array<std::array<double, 4>, 4> dydz{};

  explicit SlabCut(const std::array<Eigen::Vector3d, 4>& vertex) {
    auto order = [&](int p, int q) {
      if (vertex[o[q]][2] < vertex[o[p]][2]) std::swap(o[p], o[q]);
    };
    order(0, 1);
    order(2, 3);
    order(0, 2);
    order(1, 3);
    order(1, 2);
    for (int k = 0; k <= 3; ++k) {
      zv[k] = vertex[o[k]][2];
      yv[k] = vertex[o[k]][1];
    }
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b <= 3; ++b)
        if (zv[b] > zv[a]) dydz[a][b] = (yv[b] - yv[a]) / (zv[b] - zv[a]);
  }
  // y on edge (a, b), a < b in that order; only evaluated for zv[a] < z < zv[b].
  double edge_y(int a, int b, double z) const { return yv[a] + (z - zv[a]) * dydz[a][b]; }

  // The row range [*r0, *r1] of slab z within [lo1, hi1]; false if empty.
  bool rows(const std::array<Eigen::Vector3d, 4>& vertex, double margin, double z, long lo1, long hi1,
            long* r0, long* r1) const {
    double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
    const int m = (z > zv[1]) + (z > zv[2]);
    if (z - zv[m] > margin && zv[m + 1] - z > margin) {
      // The cut edges of interval m (repeating one where there are only three).
      static constexpr int cut[3][4][2] = {{{0, 3}, {0, 1}, {0, 2}, {0, 2}},
                                           {{0, 3}, {0, 2}, {1, 2}, {1, 3}},
                                           {{0, 3}, {1, 3}, {2, 3}, {2, 3}}};
      const double y03 = edge_y(0, 3, z), y1 = edge_y(cut[m][1][0], cut[m][1][1], z),
                   y2 = edge_y(cut[m][2][0], cut[m][2][1], z), y3 = edge_y(cut[m][3][0], cut[m][3][1], z);
      ymin = std::min(std::min(y03, y1), std::min(y2, y3));
      ymax = std::max(std::max(y03, y1), std::max(y2, y3));
    } else {
      for (int p = 0; p <= 3; ++p) {
        const Eigen::Vector3d& u = vertex[p];
        if (std::abs(u[2] - z) <= margin) {
          ymin = std::min(ymin, u[1]);
          ymax = std::max(ymax, u[1]);
        }
        for (int q = p + 1; q <= 3; ++q) {
          const Eigen::Vector3d& w = vertex[q];
          if ((u[2] - z) * (w[2] - z) < 0.0) {
            const double y = u[1] + (z - u[2]) / (w[2] - u[2]) * (w[1] - u[1]);
            ymin = std::min(ymin, y);
            ymax = std::max(ymax, y);
          }
        }
      }
    }
    if (!(ymin <= ymax)) {  // slab only within the margin of the simplex: scan the whole range
      ymin = static_cast<double>(lo1);
      ymax = static_cast<double>(hi1);
    }
    *r0 = std::max(lo1, ceil_long(std::max(ymin - margin, static_cast<double>(lo1) - 1.0)));
    *r1 = std::min(hi1, floor_long(std::min(ymax + margin, static_cast<double>(hi1) + 1.0)));
    return *r0 <= *r1;
  }
};

}  // namespace vim::detail

// Exact overlap of a simplex with axis-aligned boxes, by plane splits (tests only; independent of the
// mesher's voxel enumeration): a simplex clipped by a half-space is cut into simplices (a prism into 3
// tetrahedra, a quadrilateral into 2 triangles), so volumes are sums of determinants, exact up to
// round-off also when vertices lie on the clipping planes. integral_over_simplex gives ∫_τ h dx of a
// voxel-wise constant image h, the truth of the Eq. 15 tests.
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>
#include <vim/image.hpp>

namespace vim::test {

template <int dim>
using ClipSimplex = std::array<Eigen::Matrix<double, dim, 1>, dim + 1>;

template <int dim>
double simplex_volume(const ClipSimplex<dim>& x) {
  Eigen::Matrix<double, dim, dim> m;
  for (int a = 0; a < dim; ++a) m.col(a) = x[a + 1] - x[0];
  return std::abs(m.determinant()) / (dim == 3 ? 6.0 : 2.0);
}

// The part of x where coordinate `axis` is <= bound (upper) or >= bound (!upper), as simplices.
template <int dim>
void clip_simplex(const ClipSimplex<dim>& x, int axis, double bound, bool upper,
                  std::vector<ClipSimplex<dim>>& out) {
  using P = Eigen::Matrix<double, dim, 1>;
  std::array<double, dim + 1> f;  // > 0 outside
  std::vector<int> in, outside;
  for (int i = 0; i <= dim; ++i) {
    f[i] = upper ? x[i][axis] - bound : bound - x[i][axis];
    (f[i] > 0 ? outside : in).push_back(i);
  }
  if (outside.empty()) return out.push_back(x);
  if (in.empty()) return;
  auto cut = [&](int i, int o) -> P { return x[i] + (f[i] / (f[i] - f[o])) * (x[o] - x[i]); };
  if constexpr (dim == 2) {
    if (in.size() == 1) {
      out.push_back({{x[in[0]], cut(in[0], outside[0]), cut(in[0], outside[1])}});
    } else {  // quadrilateral in0, in1, cut(in1), cut(in0)
      const P q1 = cut(in[1], outside[0]), q0 = cut(in[0], outside[0]);
      out.push_back({{x[in[0]], x[in[1]], q1}});
      out.push_back({{x[in[0]], q1, q0}});
    }
  } else {
    // One vertex in → a tetrahedron; otherwise a prism A,B,C / A',B',C' (edges AA', BB', CC').
    if (in.size() == 1) {
      out.push_back({{x[in[0]], cut(in[0], outside[0]), cut(in[0], outside[1]), cut(in[0], outside[2])}});
      return;
    }
    std::array<P, 3> A, B;
    if (in.size() == 3) {  // triangle in0,in1,in2 and its cuts towards the one outside vertex
      for (int k = 0; k < 3; ++k) A[k] = x[in[k]], B[k] = cut(in[k], outside[0]);
    } else {  // two in: triangles (in0, cut(in0,o0), cut(in0,o1)) and (in1, cut(in1,o0), cut(in1,o1))
      A = {{x[in[0]], cut(in[0], outside[0]), cut(in[0], outside[1])}};
      B = {{x[in[1]], cut(in[1], outside[0]), cut(in[1], outside[1])}};
    }
    out.push_back({{A[0], A[1], A[2], B[0]}});
    out.push_back({{A[1], A[2], B[0], B[1]}});
    out.push_back({{A[2], B[0], B[1], B[2]}});
  }
}

// |x ∩ [lo, hi]|.
template <int dim>
double box_overlap(const ClipSimplex<dim>& x, const Eigen::Matrix<double, dim, 1>& lo,
                   const Eigen::Matrix<double, dim, 1>& hi) {
  std::vector<ClipSimplex<dim>> pieces{x}, next;
  for (int a = 0; a < dim && !pieces.empty(); ++a)
    for (const bool upper : {false, true}) {
      next.clear();
      for (const auto& s : pieces) clip_simplex<dim>(s, a, upper ? hi[a] : lo[a], upper, next);
      pieces.swap(next);
    }
  double v = 0.0;
  for (const auto& s : pieces) v += simplex_volume<dim>(s);
  return v;
}

struct SimplexIntegral {
  double integral = 0.0;  // ∫_τ h dx
  double covered = 0.0;   // |τ ∩ image box|
  // Range of the voxel values within one voxel of τ's bounding box: every value a voxel-centre mean or a
  // multilinear interpolation inside τ can take, and every value τ overlaps.
  double min = 0.0, max = 0.0;
};

// ∫_τ h dx for the voxel-wise constant image h: Σ_voxels h_v |τ ∩ box_v|.
template <int dim>
SimplexIntegral integral_over_simplex(const Image<dim>& image, const ClipSimplex<dim>& x) {
  using P = Eigen::Matrix<double, dim, 1>;
  P lo = x[0], hi = x[0];
  for (const auto& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  std::array<long, dim> i0, i1;
  for (int a = 0; a < dim; ++a) {
    i0[a] =
        std::max(0L, static_cast<long>(std::floor((lo[a] - image.origin[a]) / image.spacing[a] + 0.5)) - 1);
    i1[a] = std::min(image.size[a] - 1,
                     static_cast<long>(std::floor((hi[a] - image.origin[a]) / image.spacing[a] + 0.5)) + 1);
  }
  SimplexIntegral r;
  r.min = std::numeric_limits<double>::infinity();
  r.max = -r.min;
  typename Image<dim>::Index j = i0;
  while (true) {
    P blo, bhi;
    for (int a = 0; a < dim; ++a) {
      blo[a] = image.origin[a] + (static_cast<double>(j[a]) - 0.5) * image.spacing[a];
      bhi[a] = blo[a] + image.spacing[a];
    }
    const double v = box_overlap<dim>(x, blo, bhi), h = image.at(j);
    r.integral += v * h;
    r.covered += v;
    r.min = std::min(r.min, h);
    r.max = std::max(r.max, h);
    int a = 0;
    while (a < dim && ++j[a] > i1[a]) j[a] = i0[a], ++a;
    if (a == dim) break;
  }
  return r;
}

}  // namespace vim::test

// Image<dim>: a scalar voxel map in the image's axis-aligned physical frame.
// Voxel centre of index i is origin + i ⊙ spacing (ITK convention, without the direction matrix,
// which the pipeline keeps and applies at output; see docs/architecture.md, "Coordinates").
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace vim {

template <int dim>
struct Image {
  using Point = Eigen::Matrix<double, dim, 1>;
  using Index = std::array<long, dim>;

  std::array<long, dim> size{};       // voxels per axis; axis 0 varies fastest in `data`
  std::array<double, dim> spacing{};  // physical voxel size per axis (> 0)
  std::array<double, dim> origin{};   // physical position of the centre of voxel (0,...,0)
  std::vector<float> data;            // size[0]*...*size[dim-1] values

  Image() = default;
  Image(const std::array<long, dim>& sz, const std::array<double, dim>& sp,
        const std::array<double, dim>& org, float fill = 0.0f)
      : size(sz), spacing(sp), origin(org), data(count_of(sz), fill) {}

  static std::size_t count_of(const std::array<long, dim>& sz) {
    std::size_t n = 1;
    for (int a = 0; a < dim; ++a) n *= static_cast<std::size_t>(sz[a]);
    return n;
  }
  std::size_t voxel_count() const { return count_of(size); }

  std::size_t linear_index(const Index& i) const {
    std::size_t k = 0;
    for (int a = dim - 1; a >= 0; --a)
      k = k * static_cast<std::size_t>(size[a]) + static_cast<std::size_t>(i[a]);
    return k;
  }
  Index index_of(std::size_t k) const {
    Index i{};
    for (int a = 0; a < dim; ++a) {
      i[a] = static_cast<long>(k % static_cast<std::size_t>(size[a]));
      k /= static_cast<std::size_t>(size[a]);
    }
    return i;
  }
  float& at(const Index& i) { return data[linear_index(i)]; }
  float at(const Index& i) const { return data[linear_index(i)]; }

  // Physical position of a voxel centre.
  Point point_of(const Index& i) const {
    Point p;
    for (int a = 0; a < dim; ++a) p[a] = origin[a] + static_cast<double>(i[a]) * spacing[a];
    return p;
  }
  // Continuous index of a physical point (voxel centres at integers).
  Point continuous_index(const Point& p) const {
    Point c;
    for (int a = 0; a < dim; ++a) c[a] = (p[a] - origin[a]) / spacing[a];
    return c;
  }

  // The physical domain covered by the voxels: [origin - spacing/2, origin + (size - 1/2)·spacing].
  Point box_min() const {
    Point p;
    for (int a = 0; a < dim; ++a) p[a] = origin[a] - 0.5 * spacing[a];
    return p;
  }
  Point box_max() const {
    Point p;
    for (int a = 0; a < dim; ++a) p[a] = origin[a] + (static_cast<double>(size[a]) - 0.5) * spacing[a];
    return p;
  }
  double min_spacing() const {
    double s = spacing[0];
    for (int a = 1; a < dim; ++a) s = std::min(s, spacing[a]);
    return s;
  }

  // Multilinear interpolation at a physical point; clamps to the nearest voxel centre outside.
  double interpolate(const Point& p) const {
    const Point c = continuous_index(p);
    std::array<long, dim> i0{};
    std::array<double, dim> t{};
    for (int a = 0; a < dim; ++a) {
      double ca = std::min(std::max(c[a], 0.0), static_cast<double>(size[a] - 1));
      long f = static_cast<long>(std::floor(ca));
      if (f >= size[a] - 1) f = std::max(0L, size[a] - 2);
      i0[a] = f;
      t[a] = (size[a] > 1) ? ca - static_cast<double>(f) : 0.0;
    }
    double v = 0.0;
    for (int corner = 0; corner < (1 << dim); ++corner) {
      double w = 1.0;
      Index j{};
      for (int a = 0; a < dim; ++a) {
        const bool hi = (corner >> a) & 1;
        j[a] = std::min(i0[a] + (hi ? 1 : 0), size[a] - 1);
        w *= hi ? t[a] : 1.0 - t[a];
      }
      if (w != 0.0) v += w * static_cast<double>(at(j));
    }
    return v;
  }
};

}  // namespace vim

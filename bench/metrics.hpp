// Independent validation metrics for paper Table I and §VI-B (docs/validation.md): element means by a
// brute-force barycentric voxel test, the thresholded largest face-connected component, the
// FN/FP/TF voxel counts against the analytic sphere, and element quality (min NRR, min/max
// dihedral). Deliberately shares nothing with the mesher's VoxelStatistics/segment/mesh_quality:
// it reads only the mesh (points + cells) and the image, so it can check them.
#pragma once

#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <vector>

namespace vim::metrics {

template <int dim>
using Pt = Eigen::Matrix<double, dim, 1>;

// ---------------------------------------------------------------------------------------------
// Phantoms. The Table I phantom: cube [0, side]^dim of n^dim voxels (spacing side/n, first centre
// at spacing/2), value `inside` where |x − c| ≤ r for any inclusion (c, r), else `outside`.
struct Inclusion {
  double centre[3];
  double radius;
  float value;
};

template <int dim>
Image<dim> inclusion_phantom(long n, double side, const std::vector<Inclusion>& inclusions, float outside) {
  std::array<long, dim> size;
  std::array<double, dim> spacing, origin;
  size.fill(n);
  spacing.fill(side / static_cast<double>(n));
  origin.fill(0.5 * side / static_cast<double>(n));
  Image<dim> image(size, spacing, origin, outside);
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const Pt<dim> p = image.point_of(image.index_of(k));
    for (const Inclusion& inc : inclusions) {
      double r2 = 0.0;
      for (int a = 0; a < dim; ++a) r2 += (p[a] - inc.centre[a]) * (p[a] - inc.centre[a]);
      if (r2 <= inc.radius * inc.radius) image.data[k] = inc.value;
    }
  }
  return image;
}

// A synthetic 3D elastogram that is not tuned to anything: the cube [0,3]³ (n³ voxels, background
// modulus 1) with 3 to 6 spheres of random centre (in the cube), radius (0.225–0.9) and modulus
// (30%: softer, [0.2, 0.5]; otherwise stiffer, [2, 10]), later spheres over earlier ones. The draws
// use std::mt19937 directly (rng() / 2^32), so a seed gives the same image on every platform.
inline std::vector<Inclusion> random_spheres(unsigned seed) {
  std::mt19937 rng(seed);
  auto u01 = [&] { return static_cast<double>(rng()) / 4294967296.0; };
  std::vector<Inclusion> spheres;
  const int k = 3 + static_cast<int>(rng() % 4);
  for (int i = 0; i < k; ++i) {
    Inclusion s{};
    s.radius = 1.5 * (0.15 + 0.45 * u01());
    for (double& c : s.centre) c = 3.0 * u01();
    s.value = static_cast<float>(u01() < 0.3 ? 0.2 + 0.3 * u01() : 2.0 + 8.0 * u01());
    spheres.push_back(s);
  }
  return spheres;
}
inline Image<3> random_spheres_phantom(long n, unsigned seed) {
  return inclusion_phantom<3>(n, 3.0, random_spheres(seed), 1.0f);
}

// Paper §VI-A: 100³ voxels, cube [0,3]³, sphere r = 1 at the centre, 2.0 inside / 1.0 outside.
inline Image<3> table1_phantom(long n = 100, float inside = 2.0f, float outside = 1.0f) {
  return inclusion_phantom<3>(n, 3.0, {{{1.5, 1.5, 1.5}, 1.0, inside}}, outside);
}

// ---------------------------------------------------------------------------------------------
// Brute-force voxel enclosure: visit every voxel centre of the element's bounding box and test its
// barycentric coordinates (all ≥ −tol). Centres on shared faces may be reported by both elements;
// callers that need each voxel once mark a visited mask.
template <int dim>
struct Barycentric {
  Eigen::Matrix<double, dim, dim> inverse;
  Pt<dim> x0;
  bool valid = false;
  explicit Barycentric(const std::array<Pt<dim>, dim + 1>& x) : x0(x[0]) {
    Eigen::Matrix<double, dim, dim> t;
    for (int k = 0; k < dim; ++k) t.col(k) = x[k + 1] - x[0];
    Eigen::FullPivLU<Eigen::Matrix<double, dim, dim>> lu(t);
    valid = lu.isInvertible();
    if (valid) inverse = lu.inverse();
  }
  bool contains(const Pt<dim>& p, double tol) const {
    if (!valid) return false;
    const Pt<dim> l = inverse * (p - x0);
    return l.minCoeff() >= -tol && 1.0 - l.sum() >= -tol;
  }
};

// Calls f(linear voxel index) for every voxel centre inside simplex x (tolerance tol).
template <int dim, class F>
void for_each_voxel_in(const Image<dim>& image, const std::array<Pt<dim>, dim + 1>& x, double tol, F&& f) {
  const Barycentric<dim> bary(x);
  if (!bary.valid) return;
  std::array<long, dim> lo, hi;
  for (int a = 0; a < dim; ++a) {
    double mn = x[0][a], mx = x[0][a];
    for (int k = 1; k <= dim; ++k) mn = std::min(mn, x[k][a]), mx = std::max(mx, x[k][a]);
    lo[a] = std::max(0L, static_cast<long>(std::ceil((mn - image.origin[a]) / image.spacing[a] - 1e-9)));
    hi[a] = std::min(image.size[a] - 1, static_cast<long>(std::floor((mx - image.origin[a]) / image.spacing[a] + 1e-9)));
    if (hi[a] < lo[a]) return;
  }
  typename Image<dim>::Index i = lo;
  while (true) {
    if (bary.contains(image.point_of(i), tol)) f(image.linear_index(i));
    int a = 0;
    for (; a < dim; ++a) {
      if (++i[a] <= hi[a]) break;
      i[a] = lo[a];
    }
    if (a == dim) break;
  }
}

struct BruteForceValues {
  std::vector<double> mean;  // per cell: mean of enclosed voxel values (centroid sample if none)
  std::vector<long> voxels;  // per cell: enclosed voxel centres
};

template <int dim>
BruteForceValues element_means(const Image<dim>& image, const SimplexMesh<dim>& mesh, double tol = 1e-9) {
  BruteForceValues v;
  v.mean.resize(mesh.n_cells());
  v.voxels.resize(mesh.n_cells());
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    double s = 0.0;
    long n = 0;
    for_each_voxel_in<dim>(image, x, tol, [&](std::size_t k) { s += image.data[k], ++n; });
    v.voxels[c] = n;
    v.mean[c] = n > 0 ? s / static_cast<double>(n) : image.interpolate(centroid<dim>(x));
  }
  return v;
}

// ---------------------------------------------------------------------------------------------
// §VI-B: cells with mean > threshold, grouped by shared facets (union-find); the largest group by
// cell count (ties: the one containing the lowest cell index) is the object.
template <int dim>
std::vector<bool> largest_component(const SimplexMesh<dim>& mesh, const std::vector<double>& mean, double threshold) {
  const std::size_t m = mesh.n_cells();
  std::vector<std::size_t> parent(m);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::map<std::array<int, dim>, std::size_t> facet_owner;
  for (std::size_t c = 0; c < m; ++c) {
    if (!(mean[c] > threshold)) continue;
    for (int skip = 0; skip <= dim; ++skip) {
      std::array<int, dim> f;
      for (int k = 0, j = 0; k <= dim; ++k)
        if (k != skip) f[j++] = mesh.cells[c][k];
      std::sort(f.begin(), f.end());
      auto [it, fresh] = facet_owner.emplace(f, c);
      if (!fresh) parent[find(c)] = find(it->second);
    }
  }
  std::vector<long> count(m, 0);
  for (std::size_t c = 0; c < m; ++c)
    if (mean[c] > threshold) ++count[find(c)];
  std::size_t best = m;
  for (std::size_t c = 0; c < m; ++c)
    if (mean[c] > threshold && (best == m || count[find(c)] > count[best])) best = find(c);
  std::vector<bool> object(m, false);
  for (std::size_t c = 0; c < m; ++c) object[c] = best != m && mean[c] > threshold && find(c) == best;
  return object;
}

// ---------------------------------------------------------------------------------------------
// Table I approximation metrics: voxel centres in object cells (each voxel once) vs the analytic
// sphere |x − c| ≤ r. TF% = TF / (voxel centres in the sphere) · 100 (155,048 for the phantom).
struct SphereMetrics {
  long fn = 0, fp = 0, tf = 0, sphere_voxels = 0, object_voxels = 0, object_cells = 0;
  double tf_percent = 0.0;
};

template <int dim>
SphereMetrics sphere_metrics(const Image<dim>& image, const SimplexMesh<dim>& mesh, const std::vector<bool>& object,
                             const Pt<dim>& centre, double radius, double tol = 1e-9) {
  std::vector<std::uint8_t> in_object(image.voxel_count(), 0);
  SphereMetrics r;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    if (!object[c]) continue;
    ++r.object_cells;
    for_each_voxel_in<dim>(image, cell_points(mesh, c), tol, [&](std::size_t k) { in_object[k] = 1; });
  }
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const bool in_sphere = (image.point_of(image.index_of(k)) - centre).squaredNorm() <= radius * radius;
    r.sphere_voxels += in_sphere;
    r.object_voxels += in_object[k];
    if (in_sphere && !in_object[k]) ++r.fn;
    if (!in_sphere && in_object[k]) ++r.fp;
  }
  r.tf = r.fn + r.fp;
  r.tf_percent = r.sphere_voxels > 0 ? 100.0 * static_cast<double>(r.tf) / static_cast<double>(r.sphere_voxels) : 0.0;
  return r;
}

// The whole Table I pipeline on one mesh: brute-force means → threshold 1.5 → largest component → TF.
template <int dim>
SphereMetrics table1_metrics(const Image<dim>& image, const SimplexMesh<dim>& mesh, const Pt<dim>& centre,
                             double radius, double threshold = 1.5) {
  const BruteForceValues v = element_means<dim>(image, mesh);
  return sphere_metrics<dim>(image, mesh, largest_component<dim>(mesh, v.mean, threshold), centre, radius);
}

// ---------------------------------------------------------------------------------------------
// Quality (paper §V): worst normalised radius ratio dim·r_in/R_circ and min/max dihedral angles in
// degrees (2D: interior angles). Own formulas, independent of vim::mesh_quality.
struct Quality {
  double min_nrr = 1.0, min_angle = 180.0, max_angle = 0.0;
  long inverted = 0;
};

inline double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

template <int dim>
Quality quality(const SimplexMesh<dim>& mesh) {
  Quality q;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c) {
    const auto x = cell_points(mesh, c);
    std::array<Eigen::Vector3d, dim + 1> p;
    for (int k = 0; k <= dim; ++k) {
      p[k].setZero();
      p[k].template head<dim>() = x[k];
    }
    const double vol = signed_volume<dim>(x);
    if (vol <= 0.0) ++q.inverted;
    double nrr = 0.0;
    if constexpr (dim == 3) {
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
          int o[2], n = 0;
          for (int k = 0; k < 4; ++k)
            if (k != i && k != j) o[n++] = k;
          const Eigen::Vector3d e = (p[j] - p[i]).normalized();
          Eigen::Vector3d u = p[o[0]] - p[i], w = p[o[1]] - p[i];
          u -= u.dot(e) * e;
          w -= w.dot(e) * e;
          const double d = angle_deg(u, w);
          q.min_angle = std::min(q.min_angle, d);
          q.max_angle = std::max(q.max_angle, d);
        }
      double area = 0.0;
      for (int skip = 0; skip < 4; ++skip) {
        int f[3], n = 0;
        for (int k = 0; k < 4; ++k)
          if (k != skip) f[n++] = k;
        area += 0.5 * (p[f[1]] - p[f[0]]).cross(p[f[2]] - p[f[0]]).norm();
      }
      const double v = std::abs(vol), r_in = 3.0 * v / area;
      // Circumradius from products of opposite edge lengths: 24·V·R = sqrt(s(s-2aA)(s-2bB)(s-2cC)) form.
      const double aA = (p[0] - p[1]).norm() * (p[2] - p[3]).norm();
      const double bB = (p[0] - p[2]).norm() * (p[1] - p[3]).norm();
      const double cC = (p[0] - p[3]).norm() * (p[1] - p[2]).norm();
      const double prod = (aA + bB + cC) * (aA + bB - cC) * (aA - bB + cC) * (-aA + bB + cC);
      const double r_circ = std::sqrt(std::max(prod, 0.0)) / (24.0 * v);
      nrr = v > 0.0 ? 3.0 * r_in / r_circ : 0.0;
    } else {
      double perimeter = 0.0, prod = 1.0;
      for (int i = 0; i < 3; ++i) {
        const double d = angle_deg(p[(i + 1) % 3] - p[i], p[(i + 2) % 3] - p[i]);
        q.min_angle = std::min(q.min_angle, d);
        q.max_angle = std::max(q.max_angle, d);
        const double len = (p[(i + 1) % 3] - p[i]).norm();
        perimeter += len;
        prod *= len;
      }
      const double a = std::abs(vol), r_in = 2.0 * a / perimeter, r_circ = prod / (4.0 * a);
      nrr = a > 0.0 ? 2.0 * r_in / r_circ : 0.0;
    }
    q.min_nrr = std::min(q.min_nrr, nrr);
  }
  return q;
}

}  // namespace vim::metrics

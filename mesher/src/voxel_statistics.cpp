// Voxel enclosure by scanline rows and per-row prefix sums (DESIGN.md §3, paper Eq. 4–6): each
// voxel row covered by the simplex is clipped against its d+1 face half-spaces to one index
// interval, whose Σ(h−shift) and Σ(h−shift)² come from the prefix sums. Tie rule: see the header.
#include <vim/voxel_statistics.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vim {

template <int dim>
struct VoxelStatistics<dim>::Faces {
  std::array<Point, dim + 1> normal;  // inward normal of the face opposite vertex i (index space)
  std::array<Point, dim + 1> base;    // first face vertex in canonical order
  std::array<double, dim + 1> tol;    // |plane value| ≤ tol counts as "on the face"
  std::array<bool, dim + 1> tie_in;   // on-face points are inside across this face
  std::array<long, dim> lo, hi;       // voxel index range of the bounding box (clipped to the image)
};

namespace {

template <int dim>
using Vec = Eigen::Matrix<double, dim, 1>;

// Plane value split as n_0 (t − b_0) + R with R = Σ_{a≥1} n_a (j_a − b_a), always summed in the
// same order, so a face evaluated from either side gives exactly negated values.
template <int dim>
inline double row_rest(const Vec<dim>& n, const Vec<dim>& b, const std::array<long, dim>& j) {
  double r = 0.0;
  for (int a = 1; a < dim; ++a) r += n[a] * (static_cast<double>(j[a]) - b[a]);
  return r;
}

inline bool accepts(double f, double tol, bool tie_in) { return tie_in ? f >= -tol : f > tol; }

template <int dim>
bool lex_less(const Vec<dim>& p, const Vec<dim>& q) {
  for (int a = 0; a < dim; ++a) {
    if (p[a] < q[a]) return true;
    if (p[a] > q[a]) return false;
  }
  return false;
}

// Normal of the hyperplane through the (canonically ordered) face vertices, unoriented.
inline Vec<2> face_normal(const std::array<Vec<2>, 2>& v) {
  const Vec<2> e = v[1] - v[0];
  return Vec<2>(-e[1], e[0]);
}
inline Vec<3> face_normal(const std::array<Vec<3>, 3>& v) { return (v[1] - v[0]).cross(v[2] - v[0]); }

}  // namespace

template <int dim>
VoxelStatistics<dim>::VoxelStatistics(const Image<dim>& image) : image_(&image) {
  for (int a = 0; a < dim; ++a)
    if (image.size[a] < 1 || !(image.spacing[a] > 0.0))
      throw std::invalid_argument("image: size must be >= 1 and spacing > 0 on every axis (axis " +
                                  std::to_string(a) + " has size " + std::to_string(image.size[a]) +
                                  ", spacing " + std::to_string(image.spacing[a]) + ")");
  if (image.data.size() != image.voxel_count())
    throw std::invalid_argument("image: data holds " + std::to_string(image.data.size()) +
                                " values but size implies " + std::to_string(image.voxel_count()));
  double sum = 0.0;
  for (float v : image.data) sum += static_cast<double>(v);
  shift_ = sum / static_cast<double>(image.data.size());

  const long n0 = image.size[0];
  row_length_ = n0 + 1;
  const long rows = static_cast<long>(image.data.size()) / n0;
  prefix_s_.assign(static_cast<std::size_t>(rows * row_length_), 0.0);
  prefix_q_.assign(static_cast<std::size_t>(rows * row_length_), 0.0);
  for (long r = 0; r < rows; ++r) {
    double s = 0.0, q = 0.0;
    const std::size_t base = static_cast<std::size_t>(r * row_length_);
    for (long t = 0; t < n0; ++t) {
      const double h = static_cast<double>(image.data[static_cast<std::size_t>(r * n0 + t)]) - shift_;
      s += h;
      q += h * h;
      prefix_s_[base + static_cast<std::size_t>(t) + 1] = s;
      prefix_q_[base + static_cast<std::size_t>(t) + 1] = q;
    }
  }
  for (int a = 0; a < dim; ++a) centre_[a] = 0.5 * static_cast<double>(image.size[a] - 1);
}

// Face planes of x in continuous index space; false if x is degenerate or misses the image.
template <int dim>
bool VoxelStatistics<dim>::prepare(const Simplex& x, Faces& f) const {
  const Image<dim>& img = *image_;
  std::array<Point, dim + 1> c;
  double big = 0.0;
  for (int k = 0; k <= dim; ++k) {
    c[k] = img.continuous_index(x[k]);
    big = std::max(big, c[k].cwiseAbs().maxCoeff());
  }
  if (!std::isfinite(big)) return false;
  const double margin = 1e-6 * (1.0 + big);
  for (int a = 0; a < dim; ++a) {
    double lo = c[0][a], hi = c[0][a];
    for (int k = 1; k <= dim; ++k) {
      lo = std::min(lo, c[k][a]);
      hi = std::max(hi, c[k][a]);
    }
    const double last = static_cast<double>(img.size[a] - 1);
    lo = std::max(std::ceil(lo - margin), 0.0);
    hi = std::min(std::floor(hi + margin), last);
    if (lo > hi) return false;
    f.lo[a] = static_cast<long>(lo);
    f.hi[a] = static_cast<long>(hi);
  }
  const double centre_size = centre_.cwiseAbs().maxCoeff();
  for (int i = 0; i <= dim; ++i) {
    std::array<Point, dim> v;
    for (int k = 0, m = 0; k <= dim; ++k)
      if (k != i) v[m++] = c[k];
    std::sort(v.begin(), v.end(), lex_less<dim>);
    Point n = face_normal(v);
    double face_size = centre_size;
    for (const Point& p : v) face_size = std::max(face_size, p.cwiseAbs().maxCoeff());
    // Orientation from the opposite vertex, evaluated like every other plane value.
    double side = n[0] * (c[i][0] - v[0][0]);
    for (int a = 1; a < dim; ++a) side += n[a] * (c[i][a] - v[0][a]);
    if (side == 0.0 || !std::isfinite(side)) return false;
    if (side < 0.0) n = -n;
    const double norm1 = n.cwiseAbs().sum();
    const double tol = 1e-9 * norm1 * (1.0 + face_size);
    if (std::abs(side) <= tol) return false;  // degenerate (flat) simplex
    // Tie direction: towards the image centre, then e_0, e_1, e_2.
    double g = 0.0;
    for (int a = 0; a < dim; ++a) g += n[a] * (centre_[a] - v[0][a]);
    bool in;
    if (g > tol)
      in = true;
    else if (g < -tol)
      in = false;
    else {
      in = false;
      for (int a = 0; a < dim; ++a)
        if (std::abs(n[a]) > 1e-12 * norm1) {
          in = n[a] > 0.0;
          break;
        }
    }
    f.normal[i] = n;
    f.base[i] = v[0];
    f.tol[i] = tol;
    f.tie_in[i] = in;
  }
  return true;
}

template <int dim>
typename VoxelStatistics<dim>::Sums VoxelStatistics<dim>::sums(const Simplex& x) const {
  Sums out;
  Faces f;
  if (!prepare(x, f)) return out;
  std::array<long, dim> j = f.lo;  // j[0] unused; odometer over axes 1..dim-1
  const long size1 = dim > 1 ? image_->size[1] : 1;
  while (true) {
    long a = f.lo[0], b = f.hi[0];
    for (int i = 0; i <= dim && a <= b; ++i) {
      const Point& n = f.normal[i];
      const double b0 = f.base[i][0], tol = f.tol[i];
      const bool tie = f.tie_in[i];
      const double r = row_rest<dim>(n, f.base[i], j);
      auto ok = [&](long t) { return accepts(n[0] * (static_cast<double>(t) - b0) + r, tol, tie); };
      const double thr = tie ? -tol : tol;
      if (n[0] == 0.0) {
        if (!ok(a)) a = b + 1;
      } else if (n[0] > 0.0) {  // accepted set is [t0, ∞)
        double est = std::ceil(b0 + (thr - r) / n[0]);
        est = std::min(std::max(est, static_cast<double>(a)), static_cast<double>(b + 1));
        long t0 = static_cast<long>(est);
        while (t0 > a && ok(t0 - 1)) --t0;
        while (t0 <= b && !ok(t0)) ++t0;
        a = t0;
      } else {  // accepted set is (−∞, t1]
        double est = std::floor(b0 + (thr - r) / n[0]);
        est = std::min(std::max(est, static_cast<double>(a - 1)), static_cast<double>(b));
        long t1 = static_cast<long>(est);
        while (t1 < b && ok(t1 + 1)) ++t1;
        while (t1 >= a && !ok(t1)) --t1;
        b = t1;
      }
    }
    if (a <= b) {
      long row = 0;
      if constexpr (dim == 2) row = j[1];
      if constexpr (dim == 3) row = j[1] + size1 * j[2];
      const std::size_t base = static_cast<std::size_t>(row * row_length_);
      out.n += b - a + 1;
      out.s += prefix_s_[base + static_cast<std::size_t>(b) + 1] - prefix_s_[base + static_cast<std::size_t>(a)];
      out.q += prefix_q_[base + static_cast<std::size_t>(b) + 1] - prefix_q_[base + static_cast<std::size_t>(a)];
    }
    int ax = 1;
    for (; ax < dim; ++ax) {
      if (j[ax] < f.hi[ax]) {
        ++j[ax];
        break;
      }
      j[ax] = f.lo[ax];
    }
    if (ax == dim) break;
  }
  (void)size1;
  return out;
}

template <int dim>
bool VoxelStatistics<dim>::contains(const Simplex& x, const typename Image<dim>::Index& index) const {
  Faces f;
  if (!prepare(x, f)) return false;
  for (int a = 0; a < dim; ++a)
    if (index[a] < f.lo[a] || index[a] > f.hi[a]) return false;
  for (int i = 0; i <= dim; ++i) {
    const Point& n = f.normal[i];
    const double v = n[0] * (static_cast<double>(index[0]) - f.base[i][0]) + row_rest<dim>(n, f.base[i], index);
    if (!accepts(v, f.tol[i], f.tie_in[i])) return false;
  }
  return true;
}

template <int dim>
typename VoxelStatistics<dim>::Sums VoxelStatistics<dim>::sums_per_voxel(const Simplex& x) const {
  Sums out;
  Faces f;
  if (!prepare(x, f)) return out;
  std::array<long, dim> j = f.lo;
  while (true) {
    bool in = true;
    for (int i = 0; i <= dim && in; ++i) {
      const Point& n = f.normal[i];
      const double v = n[0] * (static_cast<double>(j[0]) - f.base[i][0]) + row_rest<dim>(n, f.base[i], j);
      in = accepts(v, f.tol[i], f.tie_in[i]);
    }
    if (in) {
      const double h = static_cast<double>(image_->at(j)) - shift_;
      ++out.n;
      out.s += h;
      out.q += h * h;
    }
    int ax = 0;
    for (; ax < dim; ++ax) {
      if (j[ax] < f.hi[ax]) {
        ++j[ax];
        break;
      }
      j[ax] = f.lo[ax];
    }
    if (ax == dim) break;
  }
  return out;
}

template <int dim>
ElementValue VoxelStatistics<dim>::value_from(const Sums& s, const Simplex& x) const {
  ElementValue v;
  v.voxels = s.n;
  if (s.n > 0) {
    const double m = s.s / static_cast<double>(s.n);
    v.mean = shift_ + m;
    v.variance = std::max(0.0, s.q / static_cast<double>(s.n) - m * m);
  } else {
    v.mean = image_->interpolate(centroid<dim>(x));
    v.variance = 0.0;
  }
  return v;
}

template class VoxelStatistics<2>;
template class VoxelStatistics<3>;

}  // namespace vim

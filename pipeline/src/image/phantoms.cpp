// Synthetic phantoms (see phantoms.hpp): the geometry of each is written so a test can recompute
// the expected value at any point independently.
#include <cmath>
#include <random>
#include <stdexcept>
#include <vim/pipeline/image/phantoms.hpp>

namespace vim::pipeline::phantoms {

namespace {

void require_size(int n, int minimum, const char* what) {
  if (n < minimum || n > 2000)
    throw std::invalid_argument(std::string(what) + ": size " + std::to_string(n) + " out of range [" +
                                std::to_string(minimum) + ", 2000]");
}

// Fills a 2D image of n×n pixels over [lo, lo+length]² with f(x, y) at the pixel centres.
template <class F>
OrientedImage<2> raster2d(int n, double lo, double length, F f) {
  const double h = length / n;
  OrientedImage<2> out;
  out.image = Image<2>({{n, n}}, {{h, h}}, {{lo + 0.5 * h, lo + 0.5 * h}});
  for (long j = 0; j < n; ++j)
    for (long i = 0; i < n; ++i) {
      const auto p = out.image.point_of({{i, j}});
      out.image.at({{i, j}}) = static_cast<float>(f(p[0], p[1]));
    }
  return out;
}

// One pass of the [1 2 1]/4 kernel along `axis`, edges clamped.
template <int dim>
void blur_axis(Image<dim>& img, int axis) {
  std::vector<float> src = img.data;
  const std::size_t n = img.voxel_count();
  for (std::size_t k = 0; k < n; ++k) {
    auto idx = img.index_of(k);
    const long i = idx[axis];
    auto lo = idx, hi = idx;
    lo[axis] = std::max(0L, i - 1);
    hi[axis] = std::min(img.size[axis] - 1, i + 1);
    img.data[k] = 0.25f * src[img.linear_index(lo)] + 0.5f * src[k] + 0.25f * src[img.linear_index(hi)];
  }
}

// Standard normal samples from mt19937_64 (fully specified by the C++ standard) via Box–Muller,
// so the phantom is bit-identical across standard libraries.
class Normal {
 public:
  explicit Normal(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (have_) {
      have_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53;
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    have_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::mt19937_64 rng_;
  bool have_ = false;
  double spare_ = 0.0;
};

}  // namespace

long table1_sphere_voxels(int n) {
  // |x − c|² ≤ 1 with x − c = (3/(2n))·(2i + 1 − n): 9·Σ(2i+1−n)² ≤ 4n², exact in integers.
  long count = 0;
  const long lim = 4L * n * n;
  for (long k = 0; k < n; ++k)
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) {
        const long a = 2 * i + 1 - n, b = 2 * j + 1 - n, c = 2 * k + 1 - n;
        if (9 * (a * a + b * b + c * c) <= lim) ++count;
      }
  return count;
}

OrientedImage<3> table1(int n) {
  require_size(n, 2, "table1");
  const double h = 3.0 / n;
  OrientedImage<3> out;
  out.image = Image<3>({{n, n, n}}, {{h, h, h}}, {{0.5 * h, 0.5 * h, 0.5 * h}}, 1.0f);
  const long lim = 4L * n * n;
  for (long k = 0; k < n; ++k)
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) {
        const long a = 2 * i + 1 - n, b = 2 * j + 1 - n, c = 2 * k + 1 - n;
        if (9 * (a * a + b * b + c * c) <= lim) out.image.at({{i, j, k}}) = 2.0f;
      }
  return out;
}

int prostate_label(const double p[3], const ProstateGeometry& g) {
  const auto sq = [](double v) { return v * v; };
  double e = 0.0;
  for (int a = 0; a < 3; ++a) e += sq(p[a] / g.gland_semi_axes[a]);
  if (e <= 1.0) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) d2 += sq(p[a] - g.lesion_centre[a]);
    if (d2 <= sq(g.lesion_radius)) return kLesion;
    if (sq(p[1] - g.urethra_y) + sq(p[2] - g.urethra_z) <= sq(g.urethra_radius)) return kUrethra;
    return kGland;
  }
  const double probe2 = sq(p[1] - g.probe_y) + sq(p[2] - g.probe_z);
  if (probe2 <= sq(g.probe_radius)) return kProbe;
  if (probe2 <= sq(g.rectum_wall_radius)) return kRectumWall;
  if (sq(p[0] - g.pubic_bone_x) + sq(p[1] - g.pubic_bone_y) <= sq(g.pubic_bone_radius)) return kPubicBone;
  return kTissue;
}

const std::vector<std::string>& prostate_label_names() {
  static const std::vector<std::string> n = {"",        "tissue",      "gland",      "lesion",
                                             "urethra", "rectum_wall", "pubic_bone", "probe"};
  return n;
}

namespace {

// The phantom's grid: n voxels along x, the image (and gland) centre at the origin.
OrientedImage<3> prostate_grid(int n, const ProstateGeometry& g) {
  require_size(n, 8, "prostate");
  const double h = g.extent_mm[0] / n;
  std::array<long, 3> size{};
  std::array<double, 3> spacing{}, origin{};
  for (int a = 0; a < 3; ++a) {
    size[a] = std::max(2L, std::lround(g.extent_mm[a] / h));
    spacing[a] = h;
    origin[a] = -0.5 * static_cast<double>(size[a] - 1) * h;
  }
  OrientedImage<3> out;
  out.image = Image<3>(size, spacing, origin);
  return out;
}

}  // namespace

OrientedImage<3> prostate_labels(int n, const ProstateGeometry& g) {
  OrientedImage<3> out = prostate_grid(n, g);
  Image<3>& img = out.image;
  for (std::size_t k = 0; k < img.voxel_count(); ++k) {
    const auto p = img.point_of(img.index_of(k));
    const double x[3] = {p[0], p[1], p[2]};
    img.data[k] = static_cast<float>(prostate_label(x, g));
  }
  return out;
}

OrientedImage<3> prostate(int n, std::uint64_t seed, const ProstateGeometry& g) {
  OrientedImage<3> out = prostate_labels(n, g);
  Image<3>& img = out.image;
  for (float& v : img.data) {
    const int label = static_cast<int>(v);
    const double kpa = label == kGland     ? g.gland_kpa
                       : label == kLesion  ? g.lesion_kpa
                       : label == kUrethra ? g.urethra_kpa
                                           : g.tissue_kpa;
    v = static_cast<float>(kpa);
  }
  for (int a = 0; a < 3; ++a) blur_axis(img, a);
  Normal normal(seed);
  for (float& v : img.data) v = static_cast<float>(v * std::max(0.1, 1.0 + g.noise * normal()));
  return out;
}

OrientedImage<2> diamond(int n) {
  require_size(n, 2, "diamond");
  return raster2d(n, 0.0, 100.0, [](double x, double y) {
    return std::abs(x - 50.0) + std::abs(y - 50.0) <= 30.0 ? 2.0 : 1.0;
  });
}

OrientedImage<2> two_circles(int n) {
  require_size(n, 2, "two-circles");
  return raster2d(n, 0.0, 100.0, [](double x, double y) {
    const bool big = (x - 28.0) * (x - 28.0) + (y - 70.0) * (y - 70.0) <= 20.0 * 20.0;
    const bool small = (x - 50.0) * (x - 50.0) + (y - 50.0) * (y - 50.0) <= 5.0 * 5.0;
    return big || small ? 2.0 : 1.0;
  });
}

OrientedImage<2> two_circles_sizing(int n) {
  require_size(n, 2, "two-circles-sizing");
  return raster2d(n, 0.0, 100.0, [](double x, double y) {
    const double r2 = (x - 50.0) * (x - 50.0) + (y - 50.0) * (y - 50.0);
    return 1.0 + 9.0 * std::exp(-r2 / (2.0 * 10.0 * 10.0));
  });
}

OrientedImage<2> two_inclusions(int n) {
  require_size(n, 2, "two-inclusions");
  return raster2d(n, -30.0, 60.0, [](double x, double y) {
    if ((x - 14.0) * (x - 14.0) + (y - 10.0) * (y - 10.0) <= 5.0 * 5.0) return 150.0;
    if ((x + 12.0) * (x + 12.0) + (y + 8.0) * (y + 8.0) <= 10.0 * 10.0) return 60.0;
    return 15.0;
  });
}

const std::vector<std::string>& names() {
  static const std::vector<std::string> n = {"table1",      "prostate",           "diamond",
                                             "two-circles", "two-circles-sizing", "two-inclusions"};
  return n;
}

std::string description(const std::string& name) {
  if (name == "table1")
    return "paper Table I: cube [0,3]^3, sphere r=1 (2.0) in 1.0, SIZE^3 voxels (default 100)";
  if (name == "prostate")
    return "3D prostate elastogram (kPa, mm): 60x50x50 mm, gland 60 kPa, lesion 150 kPa, urethra 5 kPa, "
           "tissue 15 kPa; SIZE voxels along x (default 120 = 0.5 mm); --labels writes its label map";
  if (name == "diamond")
    return "paper Figs. 2-4: 100x100 mm, diamond (2.0) in 1.0, SIZE^2 pixels (default 100)";
  if (name == "two-circles")
    return "paper Fig. 13(a): 100x100 mm, circles r=20 and r=5 (2.0) in 1.0, SIZE^2 pixels (default 200)";
  if (name == "two-circles-sizing") return "paper Fig. 13(d): sizing/density field for two-circles (1..10)";
  if (name == "two-inclusions")
    return "2D elastogram (kPa, mm): 60x60 mm, inclusions 60 and 150 kPa in 15 kPa, SIZE^2 pixels (default "
           "120)";
  throw std::invalid_argument("unknown phantom '" + name + "'");
}

}  // namespace vim::pipeline::phantoms

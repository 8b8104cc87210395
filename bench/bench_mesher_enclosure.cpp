// Voxel enclosure benchmark (docs/performance.md; the paper's bottleneck): per-element voxel
// sums from scanline prefix sums (VoxelStatistics::sums, O(rows)) vs the brute-force per-voxel
// barycentric test over the element's bounding box (VoxelStatistics::sums_per_voxel, same tie rule,
// and the independent test of bench/metrics.hpp), for elements 2..30 voxels across on the 100³
// Table I phantom. Prints time per element (best of 5 interleaved rounds) and the speed-up ratio per
// size, measured in this run.
//
//   bench_mesher_enclosure [sizes ...]
#include "metrics.hpp"

#include <vim/voxel_statistics.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

using Simplex = std::array<Eigen::Vector3d, 4>;

// Regular tetrahedra with edge `edge`, random orientation, centred at random points at least one edge
// length inside the image box.
std::vector<Simplex> random_tetrahedra(const vim::Image<3>& image, double edge, int count, std::mt19937& rng) {
  const Eigen::Vector3d lo = image.box_min(), hi = image.box_max();
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss;
  const double s = edge / (2.0 * std::sqrt(2.0));
  const std::array<Eigen::Vector3d, 4> ref = {Eigen::Vector3d(1, 1, 1) * s, Eigen::Vector3d(1, -1, -1) * s,
                                              Eigen::Vector3d(-1, 1, -1) * s, Eigen::Vector3d(-1, -1, 1) * s};
  std::vector<Simplex> out;
  for (int k = 0; k < count; ++k) {
    Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
    q.normalize();
    Eigen::Vector3d c;
    for (int a = 0; a < 3; ++a) c[a] = lo[a] + edge + u01(rng) * (hi[a] - lo[a] - 2.0 * edge);
    Simplex x;
    for (int i = 0; i < 4; ++i) x[i] = c + q * ref[i];
    if (vim::signed_volume<3>(x) < 0.0) std::swap(x[0], x[1]);
    out.push_back(x);
  }
  return out;
}

template <class F>
double seconds_per_call(int calls, F&& f) {
  // Repeat until at least 0.05 s so the clock resolution does not matter.
  long reps = 0;
  const auto t0 = std::chrono::steady_clock::now();
  double elapsed = 0.0;
  do {
    f();
    ++reps;
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } while (elapsed < 0.05);
  return elapsed / static_cast<double>(reps * calls);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes;
  for (int i = 1; i < argc; ++i) sizes.push_back(std::atof(argv[i]));
  if (sizes.empty()) sizes = {2, 3, 5, 7, 10, 15, 20, 30};
  const vim::Image<3> image = vim::metrics::table1_phantom(100);
  const vim::VoxelStatistics<3> stats(image);
  std::mt19937 rng(42);
  std::printf("Voxel enclosure, 100^3 phantom, random regular tetrahedra (edge in voxels)\n");
  std::printf("%6s %10s %12s %12s %12s %10s %10s %6s\n", "edge", "voxels/el", "prefix[us]", "brute[us]",
              "indep[us]", "ratio", "ratio_ind", "match");
  for (double size : sizes) {
    const int count = size <= 5 ? 2000 : size <= 15 ? 400 : 100;
    const auto tets = random_tetrahedra(image, size * image.spacing[0], count, rng);
    long total = 0;
    bool match = true;
    for (const auto& x : tets) {
      const auto a = stats.sums(x), b = stats.sums_per_voxel(x);
      match = match && a.n == b.n && std::abs(a.s - b.s) <= 1e-9 * (1.0 + std::abs(b.s));
      total += a.n;
    }
    volatile double sink = 0.0;
    // Best of 5 rounds, the three methods interleaved within each round, so a slow moment of the
    // (shared) machine does not land on one method only.
    double t_prefix = 1e300, t_brute = 1e300, t_indep = 1e300;
    for (int round = 0; round < 5; ++round) {
      t_prefix = std::min(t_prefix, seconds_per_call(count, [&] {
        for (const auto& x : tets) sink = sink + stats.sums(x).s;
      }));
      t_brute = std::min(t_brute, seconds_per_call(count, [&] {
        for (const auto& x : tets) sink = sink + stats.sums_per_voxel(x).s;
      }));
      t_indep = std::min(t_indep, seconds_per_call(count, [&] {
        for (const auto& x : tets) {
          double s = 0.0;
          vim::metrics::for_each_voxel_in<3>(image, x, 1e-9, [&](std::size_t k) { s += image.data[k]; });
          sink = sink + s;
        }
      }));
    }
    std::printf("%6.1f %10.1f %12.3f %12.3f %12.3f %9.1fx %9.1fx %6s\n", size,
                static_cast<double>(total) / count, 1e6 * t_prefix, 1e6 * t_brute, 1e6 * t_indep,
                t_brute / t_prefix, t_indep / t_prefix, match ? "yes" : "NO");
    std::fflush(stdout);
  }
  return 0;
}

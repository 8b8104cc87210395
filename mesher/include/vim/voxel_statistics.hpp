// Voxel enclosure and per-element voxel statistics (paper Eq. 4–6; docs/architecture.md): which voxel
// centres lie in a simplex, their count n, shifted sums S = Σ(h−shift), Q = Σ(h−shift)², and the
// element mean/variance, read from per-row prefix sums in O(rows) with a consistent tie rule.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>
#include <vim/image.hpp>
#include <vim/vim.hpp>

namespace vim {

// Tie rule (documented here because every element must apply the same one): in continuous index
// space (voxel centres at integers) a centre p belongs to simplex τ iff p + ε·d(p) lies in the open
// interior of τ for infinitesimal ε, where d(p) = c* − p points to the image centre c* and, if d(p)
// is parallel to a face through p, the fixed directions e_0, e_1, e_2 break the tie in that order.
// Face planes are computed from the face's vertices in a canonical (lexicographic) order, so two
// elements sharing a face evaluate exactly negated plane values; |value| ≤ tol counts as "on the
// face" (robust on grid-aligned meshes). Hence every centre of a mesh of a convex domain that
// contains c* belongs to exactly one element, including centres on the domain boundary.
template <int dim>
class VoxelStatistics {
 public:
  using Point = Eigen::Matrix<double, dim, 1>;
  using Simplex = std::array<Point, dim + 1>;

  // Builds per-row prefix sums of (h − shift) and (h − shift)², shift = the image mean (or its median
  // when a few extreme values pulled the mean far from the common values; see the .cpp).
  explicit VoxelStatistics(const Image<dim>& image);

  struct Sums {
    long n = 0;      // voxel centres inside
    double s = 0.0;  // Σ (h − shift)
    double q = 0.0;  // Σ (h − shift)²
  };

  // Voxel centres inside x (tie rule above): O(rows), allocation-free, thread-safe.
  Sums sums(const Simplex& x) const;
  // Same result by testing every voxel centre of the bounding box with the same predicate
  // (reference for tests and the benchmark; O(voxels)).
  Sums sums_per_voxel(const Simplex& x) const;
  // True if every voxel centre that can lie in x (those of its bounding box in index space, the
  // range sums() scans) holds the same value, so x's variance is 0. Exact (an integer count of
  // "edge" voxels over the box, O(1)); false only means "not known to be uniform".
  bool uniform(const Simplex& x) const;
  // sums() if x is not uniform (returns true). If it is (returns false), no scan: `out` is a one-voxel
  // stand-in {1, h − shift, (h − shift)²} for the box's value h, or {0, 0, 0} if the box holds no
  // voxel centre. Sums of stand-ins and true sums still have zero variance iff all values are equal.
  bool varied_sums(const Simplex& x, Sums& out) const;
  // Whether the voxel centre with this index belongs to x under the tie rule.
  bool contains(const Simplex& x, const typename Image<dim>::Index& index) const;

  // mean = shift + s/n, population variance (clamped ≥ 0); n == 0 → image value at the centroid.
  // An element whose voxel centres all hold one value h gets exactly h as its mean (not shift + S/n
  // with the round-off of the sums about the shift) and variance 0.
  ElementValue value(const Simplex& x) const;
  ElementValue value_from(const Sums& s, const Simplex& x) const;

  double shift() const { return shift_; }
  const Image<dim>& image() const { return *image_; }

 private:
  struct Faces;  // per-simplex face planes in index space (defined in the .cpp)
  bool prepare(const Simplex& x, Faces& f) const;  // index_box + face planes
  bool prepare_faces(Faces& f) const;              // face planes, with f's box already set
  bool uniform_box(const std::array<long, dim>& lo, const std::array<long, dim>& hi) const;
  Sums scan(const Faces& f) const;  // the scanline sums over a prepared simplex
  // Row j's interval [a, b] of voxel centres inside the prepared simplex (empty if a > b).
  static void clip_row(const Faces& f, const std::array<long, dim>& j, long& a, long& b);
  template <class Visit>
  void visit_voxels(const Simplex& x, Visit&& visit) const;  // every voxel centre in x (tie rule)
  // x's vertices in continuous index space and the voxel index range of its bounding box (with the
  // tie tolerance's margin, clipped to the image); false if x is not finite or misses the image.
  bool index_box(const Simplex& x, std::array<Point, dim + 1>& c, double& margin, std::array<long, dim>& lo,
                 std::array<long, dim>& hi) const;

  const Image<dim>* image_;
  double shift_ = 0.0;
  long row_length_ = 0;         // size[0] + 1 prefix entries per row
  std::vector<double> prefix_;  // rows × (size[0] + 1) interleaved pairs (Σ(h−shift), Σ(h−shift)²)
  Point centre_;                // c* in index space
  // Summed-area table ((size+1) per axis) of "edge" voxels: those whose value differs from one of
  // their axis neighbours. A box holding none is uniform (it is connected through axis neighbours).
  // Counts are kept modulo 2^32 (see uniform_box).
  std::vector<std::uint32_t> edges_;
};

extern template class VoxelStatistics<2>;
extern template class VoxelStatistics<3>;

}  // namespace vim

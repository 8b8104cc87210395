// ElementValue: an element's voxel statistics, the element value h̃_j of paper Eq. 4 (the mean of
// the voxel centres it encloses) and their variance (Eq. 5–6). The mesher computes it; the
// elasticity model takes the mean as the element's Young's modulus (Eq. 15).
#pragma once

namespace vim {

// Per-element voxel statistics: n voxel centres inside, their mean and variance (paper Eq. 4–6).
struct ElementValue {
  long voxels = 0;
  double mean = 0.0;      // element value h̃_j (centroid sample when voxels == 0)
  double variance = 0.0;  // population variance of the enclosed voxel values
};

}  // namespace vim

// Label images (docs/labels.md): an integer image beside the modulus image or alone. Its checks (integer
// voxels), its nearest-neighbour resampling into the modulus image's grid (world coordinates, both
// images' direction matrices applied) and the labels it holds.
#pragma once

#include <string>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>

namespace vim::pipeline {

// InputError "FILE: voxel (i,j,k) holds V, not an integer label" for the first non-integer voxel.
template <int dim>
void check_label_image(const Image<dim>& labels, const std::string& file);

// The distinct labels of an integer image, ascending.
template <int dim>
std::vector<int> labels_present(const Image<dim>& labels);

// `labels` resampled nearest-neighbour at the voxel centres of `reference` (by world position); a centre
// outside the label image takes its nearest voxel. InputError naming `file` if the two images' boxes
// do not overlap in world coordinates.
template <int dim>
Image<dim> labels_in_grid_of(const OrientedImage<dim>& reference, const OrientedImage<dim>& labels,
                             const std::string& file);

}  // namespace vim::pipeline

// An OrientedImage from plain arrays (a library caller's voxels, or a file's as ITK read them), with
// the checks read_image makes beyond a file's header (image_io.cpp).
#pragma once

#include <string>
#include <vector>
#include <vim/pipeline/image/image_io.hpp>

namespace vim::pipeline {

// size, spacing and origin per axis (x, y[, z]), direction row-major dim × dim (column c is image axis c
// in world axes), data with axis 0 fastest. Checks that every voxel is finite and the direction
// orthonormal (InputError naming `name`; `double_voxels`: the values were doubles read as floats, which
// the NaN/Inf message then explains).
template <int dim>
OrientedImage<dim> oriented_image(const std::vector<long>& size, const std::vector<double>& spacing,
                                  const std::vector<double>& origin, const std::vector<double>& direction,
                                  std::vector<float> data, const std::string& name,
                                  bool double_voxels = false);

}  // namespace vim::pipeline

// Material of an elastic model: per-element Young's modulus from the image (Eq. 15 of the paper),
// block means for a downsampled voxel reference, and the Lamé parameters. deal.II-free.
#pragma once

#include <array>
#include <optional>
#include <utility>
#include <vector>

namespace vim::fem {

// Eq. 15: E_j = clamp(scale · mean_j, min, max) per element, from the per-element voxel means
// (the mesher's ElementValue::mean). Throws std::invalid_argument naming the element index and value
// for NaN/inf means, or a result that is not > 0 (a negative mean is fine if the clamp lifts it);
// also for scale not finite/> 0 and a clamp with min <= 0 or min > max.
std::vector<double> element_modulus(const std::vector<double>& element_mean, double scale = 1.0,
                                    std::optional<std::pair<double, double>> clamp = std::nullopt);

// Block means of a voxel image (axis 0 fastest) over factor^dim blocks, for a downsampled fine voxel
// reference; dims must be divisible by factor. Returns the coarse values; `coarse_dims` gets the size.
template <int dim>
std::vector<double> block_mean(const std::array<long, dim>& dims, const std::vector<double>& values,
                               int factor, std::array<long, dim>* coarse_dims = nullptr);

// Lamé parameters from (E, ν): {λ, μ}. 2D is plane strain everywhere in this module.
std::pair<double, double> lame_parameters(double youngs_modulus, double poisson_ratio);

// Shear modulus μ = E / (2(1 + ν)) of the linear elastic material, unchecked (for closed forms
// outside fem, e.g. the needle band's annulus compliance and the Kelvin solution).
double shear_modulus(double youngs_modulus, double poisson_ratio);

}  // namespace vim::fem

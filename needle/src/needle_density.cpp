// The needle-path mesh density (vim/needle/needle_path.hpp).
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vim/needle/needle_path.hpp>

namespace vim::needle {

template <int dim>
Image<dim> needle_density(const Image<dim>& like, const std::vector<NeedlePath<dim>>& paths,
                          double size_ratio, double radius) {
  if (!(size_ratio > 0.0 && size_ratio <= 1.0))
    throw std::invalid_argument("needle refinement size_ratio must be in (0, 1], got " +
                                std::to_string(size_ratio));
  if (!(radius > 0.0 && std::isfinite(radius)))
    throw std::invalid_argument("needle refinement radius must be > 0, got " + std::to_string(radius));
  if (paths.empty()) throw std::invalid_argument("needle refinement needs at least one needle path");
  const double peak = std::pow(size_ratio, -static_cast<double>(dim + 2));
  Image<dim> rho(like.size, like.spacing, like.origin, 1.0f);
  for (std::size_t k = 0; k < rho.data.size(); ++k) {
    const auto p = rho.point_of(rho.index_of(k));
    double d = std::numeric_limits<double>::infinity();
    for (const auto& path : paths) d = std::min(d, path.distance(p));
    const double r = d / radius;
    rho.data[k] = static_cast<float>(1.0 + (peak - 1.0) * std::exp(-r * r));
  }
  return rho;
}

template Image<2> needle_density<2>(const Image<2>&, const std::vector<NeedlePath<2>>&, double, double);
template Image<3> needle_density<3>(const Image<3>&, const std::vector<NeedlePath<3>>&, double, double);

}  // namespace vim::needle

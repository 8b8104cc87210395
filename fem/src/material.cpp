// Material of the elastic model. Eq. 15 of the paper: each element's Young's modulus is the mean of the
// image values whose voxel centres it encloses (computed by the mesher), scaled to the model's units and
// optionally clamped. Also block means of a voxel image and the material cards of the solver decks
// (vim/fem/material_description.hpp). deal.II-free (the fuzz targets compile it alone); the Lamé
// parameters are fem/src/linear_elastic_material.hpp's (lame_parameters is in postprocess.cpp).
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vim/fem/material.hpp>
#include <vim/fem/material_description.hpp>

#include "input_checks.hpp"

namespace vim::fem {

std::vector<double> element_modulus(const std::vector<double>& element_mean, double scale,
                                    std::optional<std::pair<double, double>> clamp) {
  if (!std::isfinite(scale) || !(scale > 0.0)) {
    std::ostringstream m;
    m << "element_modulus: scale must be finite and > 0, got " << scale;
    throw std::invalid_argument(m.str());
  }
  if (clamp) {
    const auto [lo, hi] = *clamp;
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo > 0.0) || !(lo <= hi)) {
      std::ostringstream m;
      m << "element_modulus: clamp [" << lo << ", " << hi << "] is invalid; need finite 0 < min <= max";
      throw std::invalid_argument(m.str());
    }
  }
  std::vector<double> e(element_mean.size());
  for (std::size_t j = 0; j < element_mean.size(); ++j) {
    const double mean = element_mean[j];
    if (!std::isfinite(mean)) {
      std::ostringstream m;
      m << "element_modulus: element " << j << " has a non-finite mean value " << mean;
      throw std::invalid_argument(m.str());
    }
    double v = scale * mean;
    if (clamp) v = std::min(std::max(v, clamp->first), clamp->second);
    if (!(v > 0.0)) {
      std::ostringstream m;
      m << "element_modulus: element " << j << " gets a non-positive modulus " << v << " (mean " << mean
        << " x scale " << scale << "); give a clamp [min, max] with min > 0 or fix the image";
      throw std::invalid_argument(m.str());
    }
    e[j] = v;
  }
  return e;
}

template <int dim>
std::vector<double> block_mean(const std::array<long, dim>& dims, const std::vector<double>& values,
                               int factor, std::array<long, dim>* coarse_dims) {
  if (factor < 1)
    throw std::invalid_argument("block_mean: factor must be >= 1, got " + std::to_string(factor));
  std::array<long, dim> cd;
  long n = 1, nc = 1;
  for (int d = 0; d < dim; ++d) {
    if (dims[d] < 1 || dims[d] % factor != 0) {
      std::ostringstream m;
      m << "block_mean: image size " << dims[d] << " along axis " << d
        << " is not a positive multiple of factor " << factor;
      throw std::invalid_argument(m.str());
    }
    cd[d] = dims[d] / factor;
    n *= dims[d];
    nc *= cd[d];
  }
  if (static_cast<long>(values.size()) != n) {
    std::ostringstream m;
    m << "block_mean: " << values.size() << " values for an image of " << n << " voxels";
    throw std::invalid_argument(m.str());
  }
  std::vector<double> out(nc, 0.0);
  for (long i = 0; i < n; ++i) {
    long rest = i, ci = 0, stride = 1;
    for (int d = 0; d < dim; ++d) {
      const long idx = rest % dims[d];
      rest /= dims[d];
      ci += (idx / factor) * stride;
      stride *= cd[d];
    }
    out[ci] += values[i];
  }
  double inv = 1.0;
  for (int d = 0; d < dim; ++d) inv /= factor;
  for (double& v : out) v *= inv;
  if (coarse_dims) *coarse_dims = cd;
  return out;
}

void MaterialDescription::write_inp_card(std::ostream& out, double youngs_modulus) const {
  if (neo_hookean)
    out << "*Hyperelastic, NEO HOOKE\n"
        << neo_hookean_c10(youngs_modulus, poisson_ratio) << ", "
        << neo_hookean_d1(youngs_modulus, poisson_ratio) << '\n';
  else
    out << "*Elastic\n" << youngs_modulus << ", " << poisson_ratio << '\n';
}

// C10 = μ/2 and D1 = 2/K with μ = E/(2(1 + ν)) and K = E/(3(1 − 2ν)), written here from E and ν so that
// the deck writer needs no deal.II unit (the scenario fuzz target compiles this file alone).
double MaterialDescription::neo_hookean_c10(double E, double nu) { return E / (4.0 * (1.0 + nu)); }
double MaterialDescription::neo_hookean_d1(double E, double nu) {
  return 2.0 / (E / (3.0 * (1.0 - 2.0 * nu)));
}

void MaterialDescription::write_feb_material(std::ostream& out, int id, const std::string& name,
                                             const std::string& modulus_map) const {
  out << "    <material id=\"" << id << "\" name=\"" << name << "\" type=\""
      << (neo_hookean ? "neo-Hookean" : "isotropic elastic") << "\">\n"
      << "      <density>1</density>\n"
      << "      <E type=\"map\">" << modulus_map << "</E>\n"
      << "      <v>" << poisson_ratio << "</v>\n"
      << "    </material>\n";
}

template std::vector<double> block_mean<2>(const std::array<long, 2>&, const std::vector<double>&, int,
                                           std::array<long, 2>*);
template std::vector<double> block_mean<3>(const std::array<long, 3>&, const std::vector<double>&, int,
                                           std::array<long, 3>*);

}  // namespace vim::fem

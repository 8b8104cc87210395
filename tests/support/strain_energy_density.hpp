// Strain energy density of a constant displacement gradient (tests only): ½ ε:C:ε for Young's modulus 1
// and Poisson ratio ν, ε = sym(∇u), C isotropic with the textbook Lamé parameters
// λ = ν/((1+ν)(1−2ν)), μ = 1/(2(1+ν)); 2D is plane strain (the 2×2 strain with ε_zz = 0).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>

namespace vim::test {

template <int dim>
double strain_energy_density(const Eigen::Matrix<double, dim, dim>& grad, double nu) {
  const Eigen::Matrix<double, dim, dim> eps = 0.5 * (grad + grad.transpose());
  const double lambda = nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), mu = 1.0 / (2.0 * (1.0 + nu));
  return 0.5 * (lambda * eps.trace() * eps.trace() + 2.0 * mu * (eps.array() * eps.array()).sum());
}

// Gradient of the P1 field with vertex values u on the simplex x.
template <int dim>
Eigen::Matrix<double, dim, dim> p1_gradient(const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& x,
                                            const std::array<Eigen::Matrix<double, dim, 1>, dim + 1>& u) {
  Eigen::Matrix<double, dim, dim> X, Du;
  for (int d = 0; d < dim; ++d) {
    X.col(d) = x[d + 1] - x[0];
    Du.col(d) = u[d + 1] - u[0];
  }
  return Du * X.inverse();
}

}  // namespace vim::test

// The Euler–Bernoulli beam of the flexible needle (vim/needle/flexible/beam.hpp).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vim/needle/flexible/beam.hpp>

namespace vim::needle {

double tube_second_moment(double outer_diameter, double inner_diameter) {
  if (!(inner_diameter >= 0.0) || !(outer_diameter > inner_diameter))
    throw std::invalid_argument("tube_second_moment: need 0 <= inner diameter < outer diameter");
  const double d4 = std::pow(outer_diameter, 4) - std::pow(inner_diameter, 4);
  return M_PI * d4 / 64.0;
}

Beam::Beam(double bending_stiffness, std::vector<double> nodes)
    : ei_(bending_stiffness), nodes_(std::move(nodes)) {
  if (!(ei_ > 0.0) || !std::isfinite(ei_)) throw std::invalid_argument("Beam: bending stiffness must be > 0");
  if (nodes_.size() < 2) throw std::invalid_argument("Beam: at least two nodes");
  for (std::size_t i = 1; i < nodes_.size(); ++i)
    if (!(nodes_[i] > nodes_[i - 1])) throw std::invalid_argument("Beam: nodes must increase strictly");
  const auto n = static_cast<Eigen::Index>(n_dofs());
  k_ = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t e = 0; e + 1 < nodes_.size(); ++e) {
    const double l = nodes_[e + 1] - nodes_[e];
    Eigen::Matrix4d ke;
    ke << 12, 6 * l, -12, 6 * l,              //
        6 * l, 4 * l * l, -6 * l, 2 * l * l,  //
        -12, -6 * l, 12, -6 * l,              //
        6 * l, 2 * l * l, -6 * l, 4 * l * l;
    k_.block<4, 4>(static_cast<Eigen::Index>(2 * e), static_cast<Eigen::Index>(2 * e)) +=
        ei_ / (l * l * l) * ke;
  }
}

Beam Beam::uniform(double bending_stiffness, double start, double length, int elements) {
  if (elements < 1 || !(length > 0.0))
    throw std::invalid_argument("Beam::uniform: need elements >= 1, length > 0");
  std::vector<double> nodes;
  for (int i = 0; i <= elements; ++i) nodes.push_back(start + length * i / elements);
  return Beam(bending_stiffness, std::move(nodes));
}

std::size_t Beam::element_of(double s) const {
  const auto it = std::upper_bound(nodes_.begin(), nodes_.end(), s);
  const auto i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - nodes_.begin()));
  return std::min(i, nodes_.size() - 1) - 1;
}

// Hermite cubics on element e, ξ = (s − s_e)/l: w = (1 − 3ξ² + 2ξ³) w_e + l(ξ − 2ξ² + ξ³) θ_e
//   + (3ξ² − 2ξ³) w_{e+1} + l(ξ³ − ξ²) θ_{e+1}.
Beam::Local Beam::local(double s) const {
  const std::size_t e = element_of(s);
  const double l = nodes_[e + 1] - nodes_[e];
  return {static_cast<Eigen::Index>(2 * e), l, std::clamp((s - nodes_[e]) / l, 0.0, 1.0)};
}

Eigen::RowVectorXd Beam::deflection_row(double s) const {
  const auto [c, l, x] = local(s);
  Eigen::RowVectorXd n = Eigen::RowVectorXd::Zero(static_cast<Eigen::Index>(n_dofs()));
  n(c) = 1 - 3 * x * x + 2 * x * x * x;
  n(c + 1) = l * (x - 2 * x * x + x * x * x);
  n(c + 2) = 3 * x * x - 2 * x * x * x;
  n(c + 3) = l * (x * x * x - x * x);
  return n;
}

Eigen::RowVectorXd Beam::slope_row(double s) const {
  const auto [c, l, x] = local(s);
  Eigen::RowVectorXd n = Eigen::RowVectorXd::Zero(static_cast<Eigen::Index>(n_dofs()));
  n(c) = (6 * x * x - 6 * x) / l;
  n(c + 1) = 1 - 4 * x + 3 * x * x;
  n(c + 2) = (6 * x - 6 * x * x) / l;
  n(c + 3) = 3 * x * x - 2 * x;
  return n;
}

Eigen::MatrixXd solve_held(const Eigen::MatrixXd& a, const Eigen::MatrixXd& f,
                           const std::vector<Eigen::Index>& held, const Eigen::MatrixXd& values) {
  const Eigen::Index n = a.rows();
  std::vector<bool> is_held(static_cast<std::size_t>(n), false);
  for (Eigen::Index h : held) is_held[static_cast<std::size_t>(h)] = true;
  std::vector<Eigen::Index> free;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!is_held[static_cast<std::size_t>(i)]) free.push_back(i);
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n, f.cols());
  for (std::size_t k = 0; k < held.size(); ++k) q.row(held[k]) = values.row(static_cast<Eigen::Index>(k));
  const auto m = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd aff(m, m), rhs(m, f.cols());
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) aff(i, j) = a(free[i], free[j]);
    rhs.row(i) = f.row(free[i]);
    for (std::size_t k = 0; k < held.size(); ++k) rhs.row(i) -= a(free[i], held[k]) * q.row(held[k]);
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(aff);
  if (m > 0 && !lu.isInvertible())
    throw std::runtime_error("solve_held: the free part of the system is singular");
  const Eigen::MatrixXd x = m > 0 ? Eigen::MatrixXd(lu.solve(rhs)) : Eigen::MatrixXd(0, f.cols());
  for (Eigen::Index i = 0; i < m; ++i) q.row(free[i]) = x.row(i);
  return q;
}

}  // namespace vim::needle

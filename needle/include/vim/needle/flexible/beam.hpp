// The needle's shaft as an Euler–Bernoulli beam (docs/needle-model.md, the flexible needle): Hermite cubic
// elements along the arc length, two degrees of freedom per node (the lateral deflection w and the slope
// θ = dw/ds) in one bending plane. A round tube bends alike in every plane through its axis, so a lateral
// vector deflection is two independent plane problems with the same matrix. Plain Eigen, dense (a needle
// has at most a few hundred nodes).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <utility>
#include <vector>

namespace vim::needle {

// The second moment of area of a tube, I = π(d_o⁴ − d_i⁴)/64. Throws std::invalid_argument unless
// 0 ≤ d_i < d_o.
double tube_second_moment(double outer_diameter, double inner_diameter);

class Beam {
 public:
  // Nodes at the arc lengths `nodes` (at least two, strictly increasing), bending stiffness EI > 0.
  // Throws std::invalid_argument otherwise.
  Beam(double bending_stiffness, std::vector<double> nodes);
  // `elements` equal elements on [start, start + length].
  static Beam uniform(double bending_stiffness, double start, double length, int elements);

  std::size_t n_nodes() const { return nodes_.size(); }
  std::size_t n_dofs() const { return 2 * nodes_.size(); }  // node i: w at 2i, θ at 2i + 1
  const std::vector<double>& nodes() const { return nodes_; }
  double bending_stiffness() const { return ei_; }
  // The assembled stiffness of the free beam, Σ_e (EI/l³)[12, 6l, −12, 6l; …] (symmetric, singular).
  const Eigen::MatrixXd& stiffness() const { return k_; }
  // The row N(s) with w(s) = N(s)·q (Hermite cubics of the element holding s; s is clamped to the
  // beam), and the row N'(s) with θ(s) = N'(s)·q.
  Eigen::RowVectorXd deflection_row(double s) const;
  Eigen::RowVectorXd slope_row(double s) const;
  double deflection(const Eigen::VectorXd& q, double s) const { return deflection_row(s).dot(q); }
  double slope(const Eigen::VectorXd& q, double s) const { return slope_row(s).dot(q); }

 private:
  std::size_t element_of(double s) const;
  // The element holding arc length s: its first DOF's index, its length l and ξ = (s − s_e)/l in [0, 1].
  struct Local {
    Eigen::Index dof;
    double l, x;
  };
  Local local(double s) const;
  double ei_;
  std::vector<double> nodes_;
  Eigen::MatrixXd k_;
};

// Solves A q = f with the degrees of freedom `held` (index, value) prescribed; the columns of f are
// independent load cases (e.g. the two bending planes) sharing the held values' index set, `values`
// one row per held index and one column per load case. Throws std::runtime_error when the free part of
// A is singular.
Eigen::MatrixXd solve_held(const Eigen::MatrixXd& a, const Eigen::MatrixXd& f,
                           const std::vector<Eigen::Index>& held, const Eigen::MatrixXd& values);

}  // namespace vim::needle

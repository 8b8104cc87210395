// The axial stiffness map of the active shaft points, which the stick-slip and force laws use for
// force control.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace vim::needle {

// The affine map from the axial values w of a fixed set of m point constraints to their axial forces,
// f = K w + c (the condensed stiffness of the embedded points along the needle; K is symmetric positive
// definite). probe() measures it with m + 1 model solves (w = 0, then w = sigma·e_j); afterwards force
// control (stick-slip, force model) is dense m×m algebra instead of one model solve per iteration.
struct AxialMap {
  Eigen::MatrixXd K;
  Eigen::VectorXd c;
  static AxialMap probe(Eigen::Index m, const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& forces,
                        double sigma);
  Eigen::VectorXd operator()(const Eigen::VectorXd& w) const { return K * w + c; }
  // Sets the free entries of w so that the forces there equal target (the other entries are kept).
  void solve_free(Eigen::VectorXd& w, const std::vector<bool>& free, const Eigen::VectorXd& target) const;
};

}  // namespace vim::needle

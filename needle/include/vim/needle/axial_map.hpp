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
// K and c may be larger than m (a tissue that keeps them at a capacity): the map of m points is their
// leading m×m block and m entries, m the size of the w handed to it.
struct AxialMap {
  Eigen::MatrixXd K;
  Eigen::VectorXd c;
  // Work space of solve_free: once reserved for m points, a solve of up to m points allocates nothing.
  struct Work {
    std::vector<Eigen::Index> free, held;
    Eigen::MatrixXd kff;
    Eigen::VectorXd rhs;
    void reserve(Eigen::Index m);
  };
  static AxialMap probe(Eigen::Index m, const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& forces,
                        double sigma);
  Eigen::VectorXd operator()(const Eigen::VectorXd& w) const {
    Eigen::VectorXd f(w.size());
    apply(w, f);
    return f;
  }
  // f = K w + c without a temporary.
  void apply(const Eigen::Ref<const Eigen::VectorXd>& w, Eigen::Ref<Eigen::VectorXd> f) const;
  // Sets the free entries of w so that the forces there equal target (the other entries are kept).
  void solve_free(Eigen::Ref<Eigen::VectorXd> w, const std::vector<bool>& free,
                  const Eigen::Ref<const Eigen::VectorXd>& target, Work& work) const;
  void solve_free(Eigen::Ref<Eigen::VectorXd> w, const std::vector<bool>& free,
                  const Eigen::Ref<const Eigen::VectorXd>& target) const {
    Work work;
    solve_free(w, free, target, work);
  }
};

}  // namespace vim::needle

// Test helper: a tissue solved by hand, every shaft point on its own axial spring (f_j = k_j·w_j).
#pragma once

#include <vector>
#include <vim/needle/shaft_state.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle::test {

// Independent springs: the axial force of active point j is k_j·w_j.
class Springs final : public TissueResponse {
 public:
  Springs(std::vector<double> k, const ShaftState& state) : k_(std::move(k)), state_(state) {}
  const std::vector<double>& solve(const std::vector<double>& axial) override {
    ++solves;
    last = axial;
    f_.assign(k_.size(), 0.0);
    for (std::size_t j : state_.active) f_[j] = k_[j] * axial[j];
    return f_;
  }
  const AxialMap& axial_map() override {
    const auto m = static_cast<Eigen::Index>(state_.active.size());
    map_.K = Eigen::MatrixXd::Zero(m, m);
    map_.c = Eigen::VectorXd::Zero(m);
    for (Eigen::Index i = 0; i < m; ++i) map_.K(i, i) = k_[state_.active[static_cast<std::size_t>(i)]];
    return map_;
  }
  int solves = 0;
  std::vector<double> last;  // the values of the last solve

 private:
  std::vector<double> k_;
  const ShaftState& state_;
  AxialMap map_;
  std::vector<double> f_;
};

}  // namespace vim::needle::test

// The band coupling of a bent needle (vim/needle/flexible/deflected_coupling.hpp).
#include <vim/needle/flexible/deflected_coupling.hpp>

namespace vim::needle {

DeflectedCoupling::DeflectedCoupling(std::unique_ptr<NeedleCoupling<3>> straight)
    : straight_(std::move(straight)) {}

void DeflectedCoupling::held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                                    std::vector<Vec>& held) const {
  straight_->held_values(active, axial, held);
  for (std::size_t i = 0; i < active.size(); ++i) {
    const std::size_t j = active[i];
    if (j >= deflection_.size()) continue;
    const fem::PointConstraint<3>& row = straight_->row_template(j);
    if (!row.components[0] || !row.components[1]) continue;  // the tip bearing: axial only
    for (int c = 0; c < 2; ++c) held[i][c] += row.axes.col(c).dot(deflection_[j]);
  }
}

}  // namespace vim::needle

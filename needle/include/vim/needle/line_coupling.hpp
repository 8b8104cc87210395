// The coupling of a thin needle: points on its axis line (2D: a plane-strain needle is a blade, and a
// line of points converges in 2D).
#pragma once

#include <vim/needle/coupling.hpp>

namespace vim::needle {

// A thin straight needle: one point constraint per shaft point, holding it on the needle's axis line
// (lateral displacement 0, or the loads' offset) at its axial value along `axis`. `axes` are the
// constraint axes (the frame axes, or the world axes seen from the frame on an oblique image whose
// supports hold world components).
template <int dim>
class LineCoupling final : public NeedleCoupling<dim> {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  using Mat = Eigen::Matrix<double, dim, dim>;
  LineCoupling(std::vector<Vec> positions, const Vec& axis, const Mat& axes);
  void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                   std::vector<Vec>& held) const override;
  const fem::PointConstraint<dim>& row_template(std::size_t j) const override { return points_[j]; }
  std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                   const fem::Solution<dim>& solution) const override;
  std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                 const fem::ElasticModel<dim>& model) const override;
  void keep_offsets(const std::vector<Vec>& displacement) override;

 private:
  std::vector<fem::PointConstraint<dim>> points_;  // per point, displacement 0
  std::vector<Vec> lateral_;
  Vec axis_;
  Mat axes_;
};

}  // namespace vim::needle

// Two solves of the same constrained problem agree (the fast path and the monolithic reference):
// every vertex displacement within rtol × the largest of the reference's, every point force within
// rtol × the largest reference point force, and (strain_energy) the strain energy within rtol. Both
// maxima must be positive, so that a zero solution cannot pass.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vim/fem/model.hpp>

namespace vim::test {

template <int dim>
void expect_solutions_agree(const fem::Solution<dim>& fast, const fem::Solution<dim>& ref, double rtol,
                            const std::string& where, bool strain_energy = true) {
  double umax = 0, fmax = 0;
  for (const auto& u : ref.vertex_displacement) umax = std::max(umax, u.norm());
  for (const auto& f : ref.point_force) fmax = std::max(fmax, f.norm());
  ASSERT_GT(umax, 0) << where;
  ASSERT_GT(fmax, 0) << where;
  ASSERT_EQ(fast.vertex_displacement.size(), ref.vertex_displacement.size()) << where;
  ASSERT_EQ(fast.point_force.size(), ref.point_force.size()) << where;
  for (std::size_t i = 0; i < ref.vertex_displacement.size(); ++i)
    ASSERT_LT((fast.vertex_displacement[i] - ref.vertex_displacement[i]).norm(), rtol * umax) << where;
  for (std::size_t k = 0; k < ref.point_force.size(); ++k)
    EXPECT_LT((fast.point_force[k] - ref.point_force[k]).norm(), rtol * fmax) << where << " point " << k;
  if (strain_energy) {
    EXPECT_NEAR(fast.strain_energy, ref.strain_energy, rtol * ref.strain_energy) << where;
  }
}

}  // namespace vim::test

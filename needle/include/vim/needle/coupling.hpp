// The rows a needle imposes on the tissue at one step (docs/architecture.md, needle coupling): a
// NeedleCoupling turns the axial values the friction law chose into the point-constraint rows of the
// model, the solution back into one axial force per shaft point, and reads the tissue near the shaft.
// A line of points in 2D (line_coupling.hpp), bands of a cylinder around the shaft in 3D
// (band_coupling.hpp). The stepping never sees which.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>
#include <vim/fem/model.hpp>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/shaft_state.hpp>

namespace vim::needle {

// The rows a needle imposes on the model at one step.
template <int dim>
class NeedleCoupling {
 public:
  using Vec = Eigen::Matrix<double, dim, 1>;
  virtual ~NeedleCoupling() = default;
  // The point constraints that hold the active points at their axial values (several rows per shaft
  // point are allowed: the forces are summed back per point by axial_forces).
  std::vector<fem::PointConstraint<dim>> rows(const std::vector<std::size_t>& active,
                                              const std::vector<double>& axial) const;
  // The same rows' displacements alone (PointConstraint::displacement, in each row's axes), written
  // into `held` (one per active point): what a step changes in rows that keep their geometry.
  virtual void held_values(const std::vector<std::size_t>& active, const std::vector<double>& axial,
                           std::vector<Vec>& held) const = 0;
  // The constraint of shaft point j with displacement 0.
  virtual const fem::PointConstraint<dim>& row_template(std::size_t j) const = 0;
  // Per shaft point: the axial force on the body of its rows in a solution of rows(active, ·).
  virtual std::vector<double> axial_forces(const std::vector<std::size_t>& active,
                                           const fem::Solution<dim>& solution) const = 0;
  // The tissue displacement the rows of `points` hold (the point's, or its band's mean) in the model's
  // last solution: where the tissue of a shaft point is before the needle takes it.
  virtual std::vector<Vec> displacements(const std::vector<std::size_t>& points,
                                         const fem::ElasticModel<dim>& model) const = 0;
  // The tissue displacement at each shaft point before the needle touches it (the external loads):
  // the rows keep its part across the axis rather than pulling the tissue back to the rest line.
  virtual void keep_offsets(const std::vector<Vec>& displacement) = 0;
  // The tissue displacement at `points` (frame) given the model's values there, `mesh_values`, in a
  // solution of rows(active, axial): a coupling whose rows stand for an analytic near field replaces
  // the model's value where the near field holds (BandCoupling); the line leaves them as they are.
  virtual std::vector<Vec> tissue_displacements(const std::vector<Vec>& points, std::vector<Vec> mesh_values,
                                                const ShaftState& state,
                                                const fem::Solution<dim>& solution) const {
    (void)points, (void)state, (void)solution;
    return mesh_values;
  }
};

}  // namespace vim::needle

// The tissue condensed onto a region of the model (DiMaio & Salcudean's condensation), for a needle
// whose path is not known in advance (vim::needle::HapticNeedle): the region's slots are the free DoFs
// of the cells whose centroid lies in the region and of the cells holding chosen points; W is the block
// of K⁻¹ on those slots and u0 = K⁻¹f there, from one factorisation and blocks of right-hand sides. A
// displacement component at a point of the region is then a short list of terms on the slots
// (terms()), so that a row of samples, its product with W and its value under u0 are dense work
// alone. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <memory>
#include <vector>
#include <vim/fem/conditions.hpp>
#include <vim/fem/model.hpp>

namespace vim::fem {

class CondensedRegion {
 public:
  // The coefficient of a slot in a value, or (slot −1) a constant (a Dirichlet value).
  struct Term {
    int slot;
    double coef;
  };

  // Condenses the model onto the DoFs of its cells whose centroid lies in `region` and of the cells
  // holding `points`. Simplex models only, serial solves. Throws std::invalid_argument for a voxel
  // model, a model whose solves run over ranks, or a point outside the mesh.
  CondensedRegion(ElasticModel<3>& model, const Region<3>& region, const std::vector<Vec<3>>& points,
                  const SolverOptions& solver = {});
  ~CondensedRegion();
  CondensedRegion(CondensedRegion&&) noexcept;

  std::size_t slots() const;
  const Eigen::MatrixXd& inverse() const;  // W: K⁻¹ on the slots (slots × slots)
  const Eigen::VectorXd& u0() const;       // K⁻¹f on the slots
  // Appends to `out` the terms of w·u_d(x), component d (model axis) of the displacement at x, in the
  // order of the cell's DoFs and their constraints. Throws std::invalid_argument when x lies outside
  // the region's cells.
  void terms(const Vec<3>& x, double w, unsigned d, std::vector<Term>& out) const;
  // The terms of all three components at once (one cell search, one evaluation of each scalar shape
  // function), w·u_d(x) appended to out[d]. Returns the model's cell holding x, or −1 (nothing appended)
  // when x lies outside the mesh; throws std::invalid_argument when x lies outside the region's cells.
  long terms(const Vec<3>& x, double w, std::array<std::vector<Term>, 3>& out) const;
  // The model's cell holding x (its locator), −1 outside the mesh.
  long locate(const Vec<3>& x) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vim::fem

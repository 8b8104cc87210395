// The fem types the needle library works with, under their needle names: the needle couples to the
// elastic model through point constraints located by the model's cell locator (vim/fem).
#pragma once

#include <Eigen/Core>
#include <vim/fem/cell_locator.hpp>
#include <vim/fem/conditions.hpp>
#include <vim/fem/point_constraints.hpp>

namespace vim::needle {

using fem::CellLocator;
using fem::PointConstraint;
using fem::Vec;

}  // namespace vim::needle

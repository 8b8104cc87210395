// A scenario region (RegionSpec) as a predicate on points of the image frame, shared by the needle
// simulation (which conditions hold which nodes) and the solver decks (which nodes and faces their
// sets hold), so that both select the same nodes.
#pragma once

#include <vim/fem/conditions.hpp>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// Box faces: the face of the frame box [box_min, box_max] within 1e-6 of its diagonal; boxes,
// spheres and cylinders: their world shape tested at transform.to_world(x).
template <int dim>
fem::Region<dim> scenario_region(const RegionSpec& region, const Eigen::Matrix<double, dim, 1>& box_min,
                                 const Eigen::Matrix<double, dim, 1>& box_max,
                                 const WorldTransform<dim>& transform);

}  // namespace vim::pipeline

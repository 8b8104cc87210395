// A scenario region (RegionSpec) as a predicate on points of the image frame, shared by the needle
// simulation (which conditions hold which nodes) and the solver decks (which nodes and faces their
// sets hold), so that both select the same nodes.
#pragma once

#include <vim/fem/conditions.hpp>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// Box faces: the face of the frame box [box_min, box_max] within 1e-6 of its diagonal; boxes,
// spheres and cylinders: their world shape tested at transform.to_world(x); a label (docs/labels.md):
// the points whose nearest voxel of `labels` (the label image in the frame) holds region.label_value.
// A label region without `labels` throws std::invalid_argument.
template <int dim>
fem::Region<dim> scenario_region(const RegionSpec& region, const Eigen::Matrix<double, dim, 1>& box_min,
                                 const Eigen::Matrix<double, dim, 1>& box_max,
                                 const WorldTransform<dim>& transform, const Image<dim>* labels = nullptr);

}  // namespace vim::pipeline

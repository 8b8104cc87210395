// The meshed model as the pipeline passes it between stages and writers: a simplex mesh in the
// image's axis-aligned physical frame, per-element statistics/modulus, and the frame→world map.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>
#include <vim/image.hpp>
#include <vim/simplex_mesh.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

// Axis-aligned physical frame -> world (ITK physical point): world = origin + D·(p − origin).
template <int dim>
struct WorldTransform {
  Eigen::Matrix<double, dim, 1> origin = Eigen::Matrix<double, dim, 1>::Zero();
  Eigen::Matrix<double, dim, dim> direction = Eigen::Matrix<double, dim, dim>::Identity();
  Eigen::Matrix<double, dim, 1> to_world(const Eigen::Matrix<double, dim, 1>& p) const {
    return origin + direction * (p - origin);
  }
  Eigen::Matrix<double, dim, 1> to_frame(const Eigen::Matrix<double, dim, 1>& w) const {
    return origin + direction.transpose() * (w - origin);  // direction is orthonormal (ITK)
  }
  // A vector (displacement, force) from frame to world axes.
  Eigen::Matrix<double, dim, 1> vector_to_world(const Eigen::Matrix<double, dim, 1>& v) const {
    return direction * v;
  }
  Eigen::Matrix<double, dim, 1> vector_to_frame(const Eigen::Matrix<double, dim, 1>& v) const {
    return direction.transpose() * v;
  }
  // The world axis that image axis c lies along (±), or -1 if it lies along none (an oblique image).
  int world_axis_of(int c) const {
    for (int a = 0; a < dim; ++a)
      if (std::abs(std::abs(direction(a, c)) - 1.0) < 1e-9) return a;
    return -1;
  }
  // Every image axis lies along a world axis: the direction matrix is a signed permutation.
  bool axis_aligned() const {
    for (int c = 0; c < dim; ++c)
      if (world_axis_of(c) < 0) return false;
    return true;
  }
};

template <int dim>
struct MeshModel {
  SimplexMesh<dim> mesh;             // frame coordinates, positively oriented
  std::vector<ElementValue> values;  // per cell: voxel count, mean, variance
  std::vector<double>
      youngs_modulus;        // per cell (Eq. 15: scaled/clamped mean); may be empty before the model stage
  std::vector<int> segment;  // per cell component id (-1 none); empty when no threshold
  std::vector<int> object;   // per cell 1 if in the largest component; empty when no threshold
  // --labels (docs/labels.md): per cell its label by the majority rule (empty without labels), and the
  // labels whose Young's modulus the label table gives (the others take Eq. 15 from the image's mean).
  std::vector<int> label;
  std::map<int, double> label_modulus;
  std::map<int, std::string> label_name;          // every label of the image: the table's name or label_N
  std::shared_ptr<const Image<dim>> label_image;  // the label image in the frame (label regions)
  WorldTransform<dim> transform;
};

// Named fields for unstructured-grid writers. Each field has n_components values per entity,
// stored entity-major. Vectors/tensors given in the frame are rotated to world by the writer's caller.
struct Field {
  int components = 1;
  std::vector<double> values;
};
using FieldMap = std::map<std::string, Field>;

}  // namespace vim::pipeline

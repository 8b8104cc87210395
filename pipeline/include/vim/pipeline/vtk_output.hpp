// VTK XML output (.vtu, .pvd) through VTK 9, in world coordinates, for ParaView and 3D Slicer.
// Every file goes through write_atomically (temporary name, then rename).
#pragma once

#include <vim/pipeline/model.hpp>

#include <array>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace vim::pipeline {

// A single-cell-type unstructured grid. Points are 3D (2D meshes get z = 0).
struct UnstructuredGrid {
  std::vector<std::array<double, 3>> points;
  int vtk_cell_type = 10;        // VTK_TRIANGLE = 5, VTK_TETRA = 10, VTK_QUAD = 9, VTK_HEXAHEDRON = 12, VTK_PIXEL = 8, VTK_VOXEL = 11
  int nodes_per_cell = 4;
  std::vector<long> connectivity;  // n_cells * nodes_per_cell
  FieldMap point_data;           // 2D vectors are padded to 3 components by the writer
  FieldMap cell_data;
  std::size_t n_cells() const { return nodes_per_cell ? connectivity.size() / nodes_per_cell : 0; }
};

// Grid of a simplex mesh in WORLD coordinates (transform applied), no fields.
template <int dim>
UnstructuredGrid simplex_grid(const SimplexMesh<dim>& frame_mesh, const WorldTransform<dim>& transform);

void write_vtu(const std::filesystem::path& path, const UnstructuredGrid& grid);

// ParaView collection: (time, file relative to the .pvd) pairs.
void write_pvd(const std::filesystem::path& path, const std::vector<std::pair<double, std::string>>& entries);

}  // namespace vim::pipeline

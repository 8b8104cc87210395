// VTK XML output (.vtu, .vtp, .pvd) through VTK 9, in world coordinates, for ParaView and 3D Slicer.
// Every file goes through write_atomically (temporary name, then rename).
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>
#include <vim/pipeline/common/model.hpp>

namespace vim::pipeline {

// A single-cell-type unstructured grid. Points are 3D (2D meshes get z = 0).
struct UnstructuredGrid {
  std::vector<std::array<double, 3>> points;
  int vtk_cell_type = 10;  // VTK_TRIANGLE = 5, VTK_TETRA = 10, VTK_QUAD = 9, VTK_HEXAHEDRON = 12, VTK_PIXEL =
                           // 8, VTK_VOXEL = 11, VTK_QUADRATIC_TRIANGLE = 22, VTK_QUADRATIC_TETRA = 24
  int nodes_per_cell = 4;
  std::vector<long> connectivity;  // n_cells * nodes_per_cell
  FieldMap point_data;             // 2D vectors are padded to 3 components by the writer
  FieldMap cell_data;
  std::size_t n_cells() const { return nodes_per_cell ? connectivity.size() / nodes_per_cell : 0; }
};

// Grid of a simplex mesh in WORLD coordinates (transform applied), no fields. Cells are positively
// oriented in the world: a mirroring direction matrix (det < 0, e.g. NIfTI qfac = -1) would turn every
// positively oriented frame cell inside out, so two of its vertices are then swapped.
template <int dim>
UnstructuredGrid simplex_grid(const SimplexMesh<dim>& frame_mesh, const WorldTransform<dim>& transform);
// Grid of a simplex mesh that is already in world coordinates and positively oriented there
// (world_mesh in exports.hpp): its points and cells as they are.
template <int dim>
UnstructuredGrid simplex_grid(const SimplexMesh<dim>& world_mesh);

// A linear simplex grid (either simplex_grid) with quadratic cells (VTK_QUADRATIC_TETRA = 24,
// VTK_QUADRATIC_TRIANGLE = 22) for P2 fields: its points, then one mid-edge point per edge in
// quadratic_cells' numbering; `edges` (if given) gets each mid-edge point's vertex pair
// (ElasticModel::edge_midpoint_displacement's input). Throws std::invalid_argument for other cells.
template <int dim>
UnstructuredGrid quadratic_simplex_grid(const UnstructuredGrid& linear,
                                        std::vector<std::array<int, 2>>* edges = nullptr);

// Corner order of a VTK quad / hexahedron over a voxel, as (x, y) index offsets of each z layer: (0,0),
// (1,0), (1,1), (0,1), counter-clockwise in the frame; reversed in-plane when the direction matrix
// mirrors, so that the world cell is positively oriented (VTK's convention) either way.
std::array<std::array<int, 2>, 4> voxel_corner_order(bool mirrored);

// Grid of an image's voxels in WORLD coordinates: one quad (2D) / hexahedron (3D) per voxel, in the
// image's voxel order, on the lattice of voxel corners numbered lexicographically (axis 0 fastest),
// which is also the vertex numbering of fem::ElasticModel::voxel_grid; corners in voxel_corner_order.
template <int dim>
UnstructuredGrid voxel_grid(const Image<dim>& image, const WorldTransform<dim>& transform);

void write_vtu(const std::filesystem::path& path, const UnstructuredGrid& grid);

// Polylines (VTK XML PolyData, .vtp): 3D points, each line a list of point indices in order, and point
// data (2D vectors padded to 3 components, as write_vtu does).
struct PolyLines {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<long>> lines;
  FieldMap point_data;
};

// Written by vtkXMLPolyDataWriter under a temporary name (the checks of write_vtu); throws
// std::invalid_argument for a line that refers to a missing point or a field of the wrong size.
void write_vtp(const std::filesystem::path& path, const PolyLines& lines);

// The cells `cells` (indices into `grid`, in this order) of `grid` with the points they use
// (renumbered in order of first use; `points_used`, if given, gets the grid point of each) and their
// point and cell fields: a piece of a parallel VTU. Throws std::invalid_argument for a cell index out
// of range.
UnstructuredGrid grid_cells(const UnstructuredGrid& grid, const std::vector<std::size_t>& cells,
                            std::vector<std::size_t>* points_used = nullptr);

// The file of piece r of the parallel VTU `relative`: "steps/step_0003.pvtu" -> "steps/step_0003_1.vtu".
std::string pvtu_piece(const std::string& relative, int r);

// The .pvtu at `path` naming `pieces` pieces STEM_0.vtu … next to it (pvtu_piece), with the point and
// cell arrays of `fields` (any piece: the arrays' names and components, as write_vtu writes them);
// written atomically. Write it after its pieces, so that it never names a missing one.
void write_pvtu(const std::filesystem::path& path, int pieces, const UnstructuredGrid& fields);

// A data set of a ParaView collection: its time, its file (relative to the .pvd) and its part; the
// parts of one time are shown together (a step's tissue grid, part 0, and its needle, part 1).
struct PvdDataSet {
  double time = 0.0;
  std::string file;
  int part = 0;
};

// ParaView collection of `entries`, in order.
void write_pvd(const std::filesystem::path& path, const std::vector<PvdDataSet>& entries);

}  // namespace vim::pipeline

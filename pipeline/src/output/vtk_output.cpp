// VTK XML writers (see vtk_output.hpp): vtkUnstructuredGrid and vtkPolyData with double-precision points
// and data arrays, written by VTK's XML writers (appended binary, zlib) under a temporary name; the .pvd
// collection is a few lines of XML written by hand.
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCommand.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkExecutive.h>
#include <vtkIdTypeArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <algorithm>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/quadratic_cells.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "output/xml_text.hpp"

namespace vim::pipeline {

namespace fs = std::filesystem;

template <int dim>
UnstructuredGrid simplex_grid(const SimplexMesh<dim>& frame_mesh, const WorldTransform<dim>& transform) {
  UnstructuredGrid g;
  g.vtk_cell_type = dim == 3 ? 10 : 5;
  g.nodes_per_cell = dim + 1;
  g.points.reserve(frame_mesh.n_points());
  for (const auto& p : frame_mesh.points) {
    const auto w = transform.to_world(p);
    std::array<double, 3> q{};
    for (int a = 0; a < dim; ++a) q[a] = w[a];
    g.points.push_back(q);
  }
  g.connectivity.reserve(frame_mesh.n_cells() * (dim + 1));
  const bool mirrored = transform.direction.determinant() < 0.0;
  for (const auto& c : frame_mesh.cells) {
    g.connectivity.push_back(c[mirrored ? 1 : 0]);
    g.connectivity.push_back(c[mirrored ? 0 : 1]);
    for (int k = 2; k <= dim; ++k) g.connectivity.push_back(c[k]);
  }
  return g;
}

template <int dim>
UnstructuredGrid quadratic_simplex_grid(const UnstructuredGrid& linear,
                                        std::vector<std::array<int, 2>>* edges) {
  if (linear.vtk_cell_type != (dim == 3 ? 10 : 5) || linear.nodes_per_cell != dim + 1)
    throw std::invalid_argument(
        "quadratic_simplex_grid: the grid is not a linear simplex grid of the dimension");
  UnstructuredGrid g = linear;
  std::vector<std::array<int, dim + 1>> cells(linear.n_cells());
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int k = 0; k <= dim; ++k) cells[c][k] = static_cast<int>(g.connectivity[c * (dim + 1) + k]);
  const QuadraticCells<dim> q = quadratic_cells<dim>(cells, g.points.size());
  for (const auto& [a, b] : q.edges) {
    std::array<double, 3> mid{};
    for (int k = 0; k < 3; ++k) mid[k] = 0.5 * (g.points[a][k] + g.points[b][k]);
    g.points.push_back(mid);
  }
  g.vtk_cell_type = dim == 3 ? 24 : 22;
  g.nodes_per_cell = QuadraticCells<dim>::nodes_per_cell;
  g.connectivity.clear();
  for (const auto& c : q.cells) g.connectivity.insert(g.connectivity.end(), c.begin(), c.end());
  if (edges) *edges = q.edges;
  return g;
}

std::array<std::array<int, 2>, 4> voxel_corner_order(bool mirrored) {
  if (mirrored) return {{{{0, 0}}, {{0, 1}}, {{1, 1}}, {{1, 0}}}};
  return {{{{0, 0}}, {{1, 0}}, {{1, 1}}, {{0, 1}}}};
}

template <int dim>
UnstructuredGrid voxel_grid(const Image<dim>& image, const WorldTransform<dim>& transform) {
  UnstructuredGrid g;
  g.vtk_cell_type = dim == 3 ? 12 : 9;
  g.nodes_per_cell = 1 << dim;
  std::array<long, dim> np{};
  std::size_t n_points = 1;
  for (int a = 0; a < dim; ++a) n_points *= static_cast<std::size_t>(np[a] = image.size[a] + 1);
  g.points.reserve(n_points);
  for (std::size_t k = 0; k < n_points; ++k) {
    std::size_t r = k;
    Eigen::Matrix<double, dim, 1> p;
    for (int a = 0; a < dim; ++a) {
      p[a] = image.origin[a] + (static_cast<double>(r % np[a]) - 0.5) * image.spacing[a];
      r /= np[a];
    }
    const auto w = transform.to_world(p);
    std::array<double, 3> q{};
    for (int a = 0; a < dim; ++a) q[a] = w[a];
    g.points.push_back(q);
  }
  const auto order2 = voxel_corner_order(transform.direction.determinant() < 0.0);
  g.connectivity.reserve(image.voxel_count() * static_cast<std::size_t>(g.nodes_per_cell));
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const auto idx = image.index_of(k);
    for (int z = 0; z < (dim == 3 ? 2 : 1); ++z)
      for (const auto& c : order2) {
        long id = 0, stride = 1;
        for (int a = 0; a < dim; ++a) {
          const long off = a == 0 ? c[0] : a == 1 ? c[1] : z;
          id += (idx[a] + off) * stride;
          stride *= np[a];
        }
        g.connectivity.push_back(id);
      }
  }
  return g;
}

template UnstructuredGrid voxel_grid<2>(const Image<2>&, const WorldTransform<2>&);
template UnstructuredGrid voxel_grid<3>(const Image<3>&, const WorldTransform<3>&);
template <int dim>
UnstructuredGrid simplex_grid(const SimplexMesh<dim>& world_mesh) {
  UnstructuredGrid g;
  g.vtk_cell_type = dim == 3 ? 10 : 5;
  g.nodes_per_cell = dim + 1;
  g.points.reserve(world_mesh.n_points());
  for (const auto& p : world_mesh.points) {
    std::array<double, 3> q{};
    for (int a = 0; a < dim; ++a) q[a] = p[a];
    g.points.push_back(q);
  }
  g.connectivity.reserve(world_mesh.n_cells() * (dim + 1));
  for (const auto& c : world_mesh.cells)
    for (int k = 0; k <= dim; ++k) g.connectivity.push_back(c[k]);
  return g;
}

template UnstructuredGrid simplex_grid<2>(const SimplexMesh<2>&);
template UnstructuredGrid simplex_grid<3>(const SimplexMesh<3>&);
template UnstructuredGrid simplex_grid<2>(const SimplexMesh<2>&, const WorldTransform<2>&);
template UnstructuredGrid simplex_grid<3>(const SimplexMesh<3>&, const WorldTransform<3>&);
template UnstructuredGrid quadratic_simplex_grid<2>(const UnstructuredGrid&,
                                                    std::vector<std::array<int, 2>>*);
template UnstructuredGrid quadratic_simplex_grid<3>(const UnstructuredGrid&,
                                                    std::vector<std::array<int, 2>>*);

namespace {

// A complete VTK XML file ends with its closing tag (and a newline).
bool ends_with_closing_tag(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::string tag = "</VTKFile>";
  const std::streamoff n = std::min<std::streamoff>(size, 64);
  if (n < static_cast<std::streamoff>(tag.size())) return false;
  std::string tail(static_cast<std::size_t>(n), '\0');
  in.seekg(size - n);
  in.read(tail.data(), n);
  return in && tail.find(tag) != std::string::npos;
}

void add_arrays(vtkDataSetAttributes* attributes, const FieldMap& fields, std::size_t n, const char* where,
                const fs::path& path) {
  for (const auto& [name, f] : fields) {
    if (f.components < 1 || f.values.size() != n * static_cast<std::size_t>(f.components))
      throw std::invalid_argument(path.string() + ": " + where + " field '" + name + "' has " +
                                  std::to_string(f.values.size()) + " values; expected " + std::to_string(n) +
                                  " × " + std::to_string(f.components));
    const int out_components = f.components == 2 ? 3 : f.components;  // ParaView wants 3D vectors
    vtkNew<vtkDoubleArray> a;
    a->SetName(name.c_str());
    a->SetNumberOfComponents(out_components);
    a->SetNumberOfTuples(static_cast<vtkIdType>(n));
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < out_components; ++c)
        a->SetComponent(static_cast<vtkIdType>(i), c,
                        c < f.components ? f.values[i * f.components + c] : 0.0);
    attributes->AddArray(a);
  }
}

// Writes `data` with the XML writer `w` (appended binary, zlib, 64-bit headers) under a temporary name.
// VTK reports a failed write (a full disk, a file-size limit) through its error code and an error
// event, while Write() still returns 1: the event is caught (so that it is not printed as a VTK log)
// and the code and the file's closing tag are checked.
void write_xml_data(const fs::path& path, vtkXMLWriter* w, vtkDataObject* data) {
  write_atomically(path, [&](const fs::path& tmp) {
    w->SetFileName(tmp.string().c_str());
    w->SetInputData(data);
    w->SetDataModeToAppended();
    w->SetCompressorTypeToZLib();
    w->SetHeaderTypeToUInt64();
    std::string vtk_error;
    vtkNew<vtkCallbackCommand> on_error;
    on_error->SetClientData(&vtk_error);
    on_error->SetCallback([](vtkObject*, unsigned long, void* client, void* call) {
      if (call) *static_cast<std::string*>(client) = static_cast<const char*>(call);
    });
    const unsigned long observer = w->AddObserver(vtkCommand::ErrorEvent, on_error);
    vtkNew<vtkCallbackCommand> ignore;  // the pipeline's own "returned failure" report of the same error
    const unsigned long pipeline_observer = w->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, ignore);
    const int ok = w->Write();
    w->RemoveObserver(observer);
    w->GetExecutive()->RemoveObserver(pipeline_observer);
    if (ok != 1 || w->GetErrorCode() != vtkErrorCode::NoError || !vtk_error.empty() ||
        !ends_with_closing_tag(tmp)) {
      std::string why =
          vtk_error.empty() ? vtkErrorCode::GetStringFromErrorCode(w->GetErrorCode()) : vtk_error;
      const auto nl = why.find_last_not_of(" \n");
      why.erase(nl == std::string::npos ? 0 : nl + 1);
      throw std::runtime_error("cannot write " + path.string() + (why.empty() ? "" : ": " + why) +
                               " (is the disk full?)");
    }
  });
}

}  // namespace

void write_vtu(const fs::path& path, const UnstructuredGrid& grid) {
  if (grid.nodes_per_cell <= 0 || grid.connectivity.size() % grid.nodes_per_cell != 0)
    throw std::invalid_argument(path.string() + ": connectivity length is not a multiple of nodes_per_cell");
  const std::size_t np = grid.points.size();
  const std::size_t nc = grid.n_cells();

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(np));
  for (std::size_t i = 0; i < np; ++i) points->SetPoint(static_cast<vtkIdType>(i), grid.points[i].data());

  vtkNew<vtkIdTypeArray> offsets, conn;
  offsets->SetNumberOfValues(static_cast<vtkIdType>(nc + 1));
  conn->SetNumberOfValues(static_cast<vtkIdType>(grid.connectivity.size()));
  for (std::size_t c = 0; c <= nc; ++c)
    offsets->SetValue(static_cast<vtkIdType>(c), static_cast<vtkIdType>(c * grid.nodes_per_cell));
  for (std::size_t k = 0; k < grid.connectivity.size(); ++k) {
    const long v = grid.connectivity[k];
    if (v < 0 || static_cast<std::size_t>(v) >= np)
      throw std::invalid_argument(path.string() + ": cell " + std::to_string(k / grid.nodes_per_cell) +
                                  " refers to point " + std::to_string(v) + " of " + std::to_string(np));
    conn->SetValue(static_cast<vtkIdType>(k), static_cast<vtkIdType>(v));
  }
  vtkNew<vtkCellArray> cells;
  cells->SetData(offsets, conn);

  vtkNew<vtkUnstructuredGrid> ug;
  ug->SetPoints(points);
  ug->SetCells(grid.vtk_cell_type, cells);
  add_arrays(ug->GetPointData(), grid.point_data, np, "point", path);
  add_arrays(ug->GetCellData(), grid.cell_data, nc, "cell", path);

  vtkNew<vtkXMLUnstructuredGridWriter> w;
  write_xml_data(path, w, ug);
}

void write_vtp(const fs::path& path, const PolyLines& lines) {
  const std::size_t np = lines.points.size();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(np));
  for (std::size_t i = 0; i < np; ++i) points->SetPoint(static_cast<vtkIdType>(i), lines.points[i].data());
  vtkNew<vtkCellArray> cells;
  for (std::size_t l = 0; l < lines.lines.size(); ++l) {
    cells->InsertNextCell(static_cast<vtkIdType>(lines.lines[l].size()));
    for (const long v : lines.lines[l]) {
      if (v < 0 || static_cast<std::size_t>(v) >= np)
        throw std::invalid_argument(path.string() + ": line " + std::to_string(l) + " refers to point " +
                                    std::to_string(v) + " of " + std::to_string(np));
      cells->InsertCellPoint(static_cast<vtkIdType>(v));
    }
  }
  vtkNew<vtkPolyData> pd;
  pd->SetPoints(points);
  pd->SetLines(cells);
  add_arrays(pd->GetPointData(), lines.point_data, np, "point", path);
  vtkNew<vtkXMLPolyDataWriter> w;
  write_xml_data(path, w, pd);
}

void write_pvd(const fs::path& path, const std::vector<PvdDataSet>& entries) {
  write_text_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        << "  <Collection>\n";
    for (const PvdDataSet& e : entries)
      out << "    <DataSet timestep=\"" << e.time << "\" group=\"\" part=\"" << e.part << "\" file=\""
          << xml_escape(e.file) << "\"/>\n";
    out << "  </Collection>\n</VTKFile>\n";
  });
}

}  // namespace vim::pipeline

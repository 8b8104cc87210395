// The export table (docs/architecture.md, "Add an export"): one row per --export format, {name, help,
// reader, writer per dimension}. The command line (its --export check and help), RunOptions' default,
// write_exports' loop and the run's list of files all read it, so a format is one file (its writer) and
// one row (pipeline/src/output/export_registry.cpp).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace vim {
template <int dim>
struct SimplexMesh;
}  // namespace vim

namespace vim::pipeline {

struct MaterialBins;
template <int dim>
struct SolverDeck;

// What every writer receives, computed once by write_exports: the world-coordinate mesh, its material
// bins and the solver deck (nodes, cells of the export degree, the scenario's conditions).
template <int dim>
struct ExportData {
  const SimplexMesh<dim>& world;
  const MaterialBins& bins;
  const SolverDeck<dim>& deck;
};

template <int dim>
using ExportWriter = void (*)(const std::filesystem::path& path, const ExportData<dim>& data);

// One row: --export NAME writes DIR/mesh.NAME with the writer of the model's dimension.
struct ExportFormat {
  std::string name;                    // the --export value and the file's extension
  std::string option_help;             // --export's help lists "NAME (option_help)"
  std::string reader;                  // --help's list of outputs: the program that reads the file
  ExportWriter<2> write_2d = nullptr;  // nullptr: not written for 2D models (report: skipped, why)
  ExportWriter<3> write_3d = nullptr;  // nullptr: not written for 3D models
  std::string skipped_why;             // report.json exports.skipped.NAME where a writer is missing

  template <int dim>
  ExportWriter<dim> writer() const {
    if constexpr (dim == 2)
      return write_2d;
    else
      return write_3d;
  }
  bool writes(int dim) const { return dim == 2 ? write_2d != nullptr : write_3d != nullptr; }
};

// Every format, in the order the files are written.
const std::vector<ExportFormat>& export_table();
// The row of `name`; throws std::invalid_argument naming the valid list for an unknown one.
const ExportFormat& export_format(const std::string& name);
// The names, in table order: vtk, feb, msh, inp (and any format registered since).
std::vector<std::string> export_formats();
// "vtk, feb, msh, inp": the names for messages.
std::string export_format_list();

// A format added at run time after the table's rows (a library user's own, or a test's); its name must
// be new. unregister_export_format removes such a row again (a row of the table stays).
void register_export_format(const ExportFormat& row);
void unregister_export_format(const std::string& name);

}  // namespace vim::pipeline

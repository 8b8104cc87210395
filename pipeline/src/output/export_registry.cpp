// The export table (export_registry.hpp): a row per --export format. To add a format, write its
// writer in export_FORMAT.cpp and add its row here (docs/architecture.md, "Add an export").
#include <algorithm>
#include <stdexcept>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/output/exports.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

namespace {

template <int dim>
void vtk_writer(const fs::path& path, const ExportData<dim>& d) {
  write_vtk_legacy<dim>(path, d.world, d.bins);
}
void feb_writer(const fs::path& path, const ExportData<3>& d) { write_feb(path, d.deck); }
template <int dim>
void msh_writer(const fs::path& path, const ExportData<dim>& d) {
  write_msh<dim>(path, d.deck, d.bins);
}
template <int dim>
void inp_writer(const fs::path& path, const ExportData<dim>& d) {
  write_inp<dim>(path, d.deck);
}

// The table's rows, then the formats registered at run time.
struct Table {
  std::vector<ExportFormat> rows = {
      {"vtk", "legacy, deal.II GridIn", "deal.II GridIn (legacy 3.0, MaterialID)", vtk_writer<2>,
       vtk_writer<3>, ""},
      {"feb", "FEBio", "FEBio", nullptr, feb_writer,
       "FEBio has no 2D solid elements; mesh.feb is written for 3D models only"},
      {"msh", "Gmsh 4.1", "Gmsh 4.1", msh_writer<2>, msh_writer<3>, ""},
      {"inp", "Abaqus", "Abaqus", inp_writer<2>, inp_writer<3>, ""},
  };
  const std::size_t built_in = rows.size();
};

Table& table() {
  static Table t;
  return t;
}

}  // namespace

const std::vector<ExportFormat>& export_table() { return table().rows; }

const ExportFormat& export_format(const std::string& name) {
  for (const auto& row : export_table())
    if (row.name == name) return row;
  throw std::invalid_argument("unknown export format '" + name + "' (valid: " + export_format_list() + ")");
}

std::vector<std::string> export_formats() {
  std::vector<std::string> names;
  for (const auto& row : export_table()) names.push_back(row.name);
  return names;
}

std::string export_format_list() {
  std::string s;
  for (const auto& row : export_table()) s += (s.empty() ? "" : ", ") + row.name;
  return s;
}

void register_export_format(const ExportFormat& row) {
  const auto& rows = export_table();
  if (row.name.empty() || row.name == "all" || row.name == "none" ||
      std::any_of(rows.begin(), rows.end(), [&](const ExportFormat& r) { return r.name == row.name; }))
    throw std::invalid_argument("export format '" + row.name + "' is already taken");
  table().rows.push_back(row);
}

void unregister_export_format(const std::string& name) {
  auto& t = table();
  const auto first = t.rows.begin() + static_cast<std::ptrdiff_t>(t.built_in);
  t.rows.erase(std::remove_if(first, t.rows.end(), [&](const ExportFormat& r) { return r.name == name; }),
               t.rows.end());
}

}  // namespace vim::pipeline

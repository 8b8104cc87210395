// Mesh exports for other tools (docs/architecture.md): legacy VTK for deal.II's GridIn::read_vtk, FEBio
// (.feb, febio_spec 4.0), Gmsh 4.1 (.msh: physical groups for material bins, box faces and scenario regions)
// and CalculiX/Abaqus (.inp). With a scenario (--simulate) mesh.inp and mesh.feb are complete jobs: the
// scenario's conditions on node sets and surfaces, a static step, quadratic elements for degree 2
// (solver_deck.hpp). All in WORLD coordinates (direction matrix applied), every cell positively
// oriented in world space, each file written under a temporary name and renamed.
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/output/solver_deck.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

// How the files are written; the run fills it at the export call (run_write_outputs.cpp).
struct ExportOptions {
  double poisson_ratio =
      kDefaultPoissonRatio;     // ν written to .feb and .inp (nearly incompressible soft tissue)
  int max_material_bins = 255;  // material ids of .vtk/.msh stay in 1..255 (8-bit safe for every reader)
  // --simulate: the scenario whose conditions mesh.inp / mesh.feb / mesh.msh carry (regions, held
  // components, pressures, tractions, a static step), and the FEM degree of their elements (2:
  // C3D10/CPE6, tet10, 10-node tetrahedra). The model's youngs_modulus must then be the one simulated.
  const Scenario* scenario = nullptr;
  unsigned degree = 1;
};

// "vtk,msh" -> {"vtk","msh"}; "all" or "" -> every format. Throws std::invalid_argument naming an
// unknown entry and the valid list.
std::vector<std::string> parse_export_formats(const std::string& comma_separated);

// Per-element material index: the element modulus (youngs_modulus, or the element mean when that
// is empty) binned into at most max_bins bins. When there are at most max_bins distinct moduli,
// every distinct value is its own bin (exact); otherwise equal-width bins over [min, max]. Empty
// bins are dropped, so ids are 1..n_bins, ordered by modulus. A model with labels (--labels) has one
// bin per label present in its elements instead, ordered by label (docs/labels.md).
struct MaterialBins {
  std::vector<double> element_modulus;  // per element, the value that was binned
  std::vector<int> element_material;    // per element, material id in 1..n_bins
  std::vector<double> modulus;          // per bin (index id-1): mean modulus of its elements
  std::vector<double> lower, upper;     // per bin: smallest/largest element modulus in it
  std::vector<long> count;              // per bin: number of elements
  // Per bin: the MaterialID of mesh.vtk and the physical group name of mesh.msh: the bin id and
  // material_ID, or with labels (MeshModel::label) the label and its name.
  std::vector<int> material_id;
  std::vector<std::string> name;
  bool by_label = false;
  std::size_t n_bins() const { return modulus.size(); }
};

template <int dim>
MaterialBins material_bins(const MeshModel<dim>& model, int max_bins = 255);

// The mesh in world coordinates with every cell positively oriented in world space (a direction
// matrix with det < 0 mirrors the mesh; the first two vertices of each cell are then swapped).
template <int dim>
SimplexMesh<dim> world_mesh(const MeshModel<dim>& model);

// Single-format writers (world mesh + bins computed by the caller with the two functions above), run by
// the rows of the export table (export_registry.cpp).
template <int dim>
void write_vtk_legacy(const std::filesystem::path& path, const SimplexMesh<dim>& world,
                      const MaterialBins& bins);
void write_feb(const std::filesystem::path& path, const SolverDeck<3>& deck);
template <int dim>
void write_msh(const std::filesystem::path& path, const SolverDeck<dim>& deck, const MaterialBins& bins);
template <int dim>
void write_inp(const std::filesystem::path& path, const SolverDeck<dim>& deck);

// What the exports write, computed once by the caller: the model (element values and modulus) and the
// same mesh in world coordinates (world_mesh(model), which the run also writes to mesh.vtu).
template <int dim>
struct ExportInput {
  const MeshModel<dim>& model;
  const SimplexMesh<dim>& world;
  ExportOptions options = {};
};

// Writes dir/mesh.NAME for each requested format (names of export_table(), written in its order; an
// unknown name throws std::invalid_argument before anything is written) and returns report.json's
// "exports": files written, skipped formats with the reason (a row without a writer for the
// dimension: FEBio has no 2D solid elements), material_table [{id, E, E_min, E_max, elements}],
// element_modulus, poisson_ratio, degree, not_expressed (scenario features the decks do not hold), and
// warnings: without a scenario, a non-positive element modulus (an image that is not a modulus map) is warned
// about, naming the fix.
template <int dim>
nlohmann::json write_exports(const ExportInput<dim>& input, const std::filesystem::path& dir,
                             const std::vector<std::string>& formats);
// The same, with the world mesh computed here.
template <int dim>
nlohmann::json write_exports(const MeshModel<dim>& model, const std::filesystem::path& dir,
                             const std::vector<std::string>& formats, const ExportOptions& options = {});

}  // namespace vim::pipeline

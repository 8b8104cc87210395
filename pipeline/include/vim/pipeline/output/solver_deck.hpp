// The model as the solver decks (mesh.inp, mesh.feb) and mesh.msh write it: nodes in world
// coordinates (vertices, then one mid-edge node per edge for degree 2), each element's exact modulus,
// node and element-face sets for the image box faces and for every scenario region, and the scenario's
// conditions resolved on those nodes: held components (first condition wins per node and world
// component, as in fem::DirichletBC), pressures on face sets, tractions as consistent nodal forces.
// Regions are the simulation's own predicates (scenario_region), so every deck holds the nodes the
// simulation held.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/output/quadratic_cells.hpp>
#include <vim/pipeline/scenario/scenario.hpp>

namespace vim::pipeline {

template <int dim>
struct SolverDeck {
  using Vec = Eigen::Matrix<double, dim, 1>;
  unsigned degree = 1;
  std::size_t n_vertices = 0;
  std::vector<Vec> nodes;                 // world; 0-based here, 1-based in the files
  std::vector<std::vector<long>> cells;   // corners (positively oriented in the world), then mid-edge nodes
  std::vector<std::array<int, 2>> edges;  // degree 2: the vertices of mid-edge node n_vertices + e
  std::vector<double> modulus;            // per cell, exact
  std::vector<int> label;                 // per cell with --labels (MeshModel::label), else empty
  std::map<int, std::string> label_name;  // the labels' names (MeshModel::label_name)
  double poisson_ratio = kDefaultPoissonRatio;
  // material.model neo-hookean: the .inp deck holds *HYPERELASTIC, NEO HOOKE and *STEP, NLGEOM, and its
  // pressures as consistent nodal forces on the reference faces (dead loads, as solved; CalculiX's
  // *DSLOAD follows the deformed faces under NLGEOM).
  bool neo_hookean = false;

  // An element face: cell and face number 0..dim in the Abaqus/CalculiX numbering (S1..S4 of a
  // tetrahedron: corners 123, 142, 243, 341; of a triangle: 12, 23, 31).
  struct Face {
    long cell = 0;
    int face = 0;
  };
  struct Set {
    std::string name;         // NSET / SURFACE / physical group name: x_min.., BC1_fixed, ...
    std::string description;  // what it is (for comments)
    std::vector<long> nodes;  // every deck node in the region
    std::vector<Face> faces;  // boundary faces whose corners all lie in the region
  };
  std::vector<Set> box_faces;  // the 2·dim faces of the image box: x_min, x_max, y_min, ...
  std::vector<Set> regions;    // one per scenario condition (index = boundary_conditions index)

  struct Held {
    long node = 0;
    int component = 0;  // world axis
    double value = 0.0;
  };
  std::vector<Held> held;  // sorted by node, then component; one entry per held (node, component)
  struct SurfaceLoad {
    int region = 0;              // index into regions
    double pressure = 0.0;       // pressure conditions
    Vec traction = Vec::Zero();  // traction conditions (world)
    bool is_pressure = true;
  };
  std::vector<SurfaceLoad> surface_loads;
  std::vector<std::pair<long, Vec>> nodal_forces;  // tractions (and neo_hookean: pressures) as consistent
                                                   // nodal forces, summed per node
  std::vector<std::string> not_expressed;          // scenario features the decks do not hold
  bool has_conditions = false;                     // a scenario was given

  // Corner nodes (and for degree 2 the mid-edge nodes) of a face, in the element's node numbering
  // order of the face type: tri3/tri6 in 3D, line2/line3 in 2D.
  std::vector<long> face_nodes(const Face& f) const;
};

// The deck of `model` with the per-cell `modulus`; `world` is world_mesh(model) (exports.hpp), computed
// once by the caller. Without a scenario: mesh, moduli and box faces only.
template <int dim>
SolverDeck<dim> solver_deck(const MeshModel<dim>& model, const SimplexMesh<dim>& world,
                            const std::vector<double>& modulus, double poisson_ratio, unsigned degree,
                            const Scenario* scenario);

// Abaqus/CalculiX corner numbers of face f (0-based local vertices).
template <int dim>
const std::array<int, dim>& deck_face_corners(int f);

}  // namespace vim::pipeline

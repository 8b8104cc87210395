// The solver-deck model shared by mesh.inp, mesh.feb and mesh.msh (solver_deck.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <stdexcept>
#include <vim/pipeline/output/exports.hpp>
#include <vim/pipeline/output/solver_deck.hpp>
#include <vim/pipeline/scenario/scenario_regions.hpp>

namespace vim::pipeline {

template <int dim>
const std::array<int, dim>& deck_face_corners(int f) {
  static const std::array<std::array<int, 3>, 4> tet = {{{{0, 1, 2}}, {{0, 3, 1}}, {{1, 3, 2}}, {{2, 3, 0}}}};
  static const std::array<std::array<int, 2>, 3> tri = {{{{0, 1}}, {{1, 2}}, {{2, 0}}}};
  if constexpr (dim == 3)
    return tet.at(f);
  else
    return tri.at(f);
}

template <int dim>
std::vector<long> SolverDeck<dim>::face_nodes(const Face& f) const {
  const auto& corners = deck_face_corners<dim>(f.face);
  const std::vector<long>& cell = cells[f.cell];
  std::vector<long> out;
  for (int k : corners) out.push_back(cell[k]);
  if (degree < 2) return out;
  const auto& order = quadratic_edge_order<dim>();
  for (int k = 0; k < (dim == 3 ? 3 : 1); ++k) {  // edges (c0,c1), (c1,c2), (c2,c0) of the face
    const int a = corners[k], b = corners[(k + 1) % dim];
    for (std::size_t e = 0; e < order.size(); ++e)
      if ((order[e][0] == a && order[e][1] == b) || (order[e][0] == b && order[e][1] == a))
        out.push_back(cell[dim + 1 + e]);
  }
  return out;
}

namespace {

template <int dim>
using Vec = Eigen::Matrix<double, dim, 1>;

// Faces that belong to one cell only.
template <int dim>
std::vector<typename SolverDeck<dim>::Face> boundary_faces(const SimplexMesh<dim>& mesh) {
  std::map<std::array<int, dim>, int> count;
  auto key = [&](std::size_t c, int f) {
    std::array<int, dim> k;
    for (int i = 0; i < dim; ++i) k[i] = mesh.cells[c][deck_face_corners<dim>(f)[i]];
    std::sort(k.begin(), k.end());
    return k;
  };
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    for (int f = 0; f <= dim; ++f) ++count[key(c, f)];
  std::vector<typename SolverDeck<dim>::Face> out;
  for (std::size_t c = 0; c < mesh.n_cells(); ++c)
    for (int f = 0; f <= dim; ++f)
      if (count[key(c, f)] == 1) out.push_back({static_cast<long>(c), f});
  return out;
}

// Nodes and boundary faces of the deck inside `region` (frame predicate over frame node positions).
template <int dim>
typename SolverDeck<dim>::Set region_set(const SolverDeck<dim>& deck,
                                         const std::vector<Vec<dim>>& frame_nodes,
                                         const std::vector<typename SolverDeck<dim>::Face>& boundary,
                                         const fem::Region<dim>& region, std::string name) {
  typename SolverDeck<dim>::Set s;
  s.name = std::move(name);
  s.description = region.name;
  std::vector<bool> in(frame_nodes.size());
  for (std::size_t i = 0; i < frame_nodes.size(); ++i)
    if ((in[i] = region.contains(frame_nodes[i]))) s.nodes.push_back(static_cast<long>(i));
  for (const auto& f : boundary) {
    bool all = true;
    for (int k : deck_face_corners<dim>(f.face)) all = all && in[deck.cells[f.cell][k]];
    if (all) s.faces.push_back(f);
  }
  return s;
}

// Area (3D) or length (2D) of a face in the world.
template <int dim>
double face_measure(const SolverDeck<dim>& deck, const typename SolverDeck<dim>::Face& f) {
  const auto& c = deck_face_corners<dim>(f.face);
  const auto& x = deck.nodes;
  const auto& cell = deck.cells[f.cell];
  if constexpr (dim == 3)
    return 0.5 * (x[cell[c[1]]] - x[cell[c[0]]]).cross(x[cell[c[2]]] - x[cell[c[0]]]).norm();
  else
    return (x[cell[c[1]]] - x[cell[c[0]]]).norm();
}

// The unit normal of face f pointing out of its cell (away from the corner not on the face).
template <int dim>
Vec<dim> outward_normal(const SolverDeck<dim>& deck, const typename SolverDeck<dim>::Face& f) {
  const auto& c = deck_face_corners<dim>(f.face);
  const auto& x = deck.nodes;
  const auto& cell = deck.cells[f.cell];
  Vec<dim> n;
  if constexpr (dim == 3)
    n = (x[cell[c[1]]] - x[cell[c[0]]]).cross(x[cell[c[2]]] - x[cell[c[0]]]);
  else
    n = Vec<dim>(x[cell[c[1]]][1] - x[cell[c[0]]][1], x[cell[c[0]]][0] - x[cell[c[1]]][0]);
  int opposite = 0;
  while (std::find(c.begin(), c.end(), opposite) != c.end()) ++opposite;
  if (n.dot(x[cell[opposite]] - x[cell[c[0]]]) > 0.0) n = -n;
  return n.normalized();
}

const char* const axis_names[] = {"x", "y", "z"};

template <int dim>
void add_conditions(SolverDeck<dim>& deck, const Scenario& sc, const std::vector<Vec<dim>>& frame_nodes,
                    const std::vector<typename SolverDeck<dim>::Face>& boundary, const Vec<dim>& box_min,
                    const Vec<dim>& box_max, const WorldTransform<dim>& tf, const Image<dim>* labels) {
  deck.has_conditions = true;
  std::map<std::pair<long, int>, double> held;  // first condition wins per (node, world component)
  std::map<long, Vec<dim>> force;
  for (std::size_t i = 0; i < sc.boundary_conditions.size(); ++i) {
    const BoundaryConditionSpec& bc = sc.boundary_conditions[i];
    static const char* const type_names[] = {"fixed", "displacement", "pressure", "traction"};
    const std::string name = "BC" + std::to_string(i + 1) + "_" + type_names[static_cast<int>(bc.type)];
    deck.regions.push_back(region_set(deck, frame_nodes, boundary,
                                      scenario_region<dim>(bc.region, box_min, box_max, tf, labels), name));
    const auto& set = deck.regions.back();
    if (bc.support == BoundaryConditionSpec::Support::elastic) {
      deck.not_expressed.push_back("boundary_conditions[" + std::to_string(i) + "]: the elastic support of " +
                                   bc.region.describe() + " (stiffness " +
                                   std::to_string(bc.support_stiffness) + "); node set " + name +
                                   " holds its region, unsupported here");
      continue;
    }
    if (bc.is_dirichlet()) {
      for (long n : set.nodes)
        for (int c = 0; c < dim; ++c)
          if (bc.components.empty() || bc.components[c])
            held.emplace(std::pair{n, c},
                         bc.type == BoundaryConditionSpec::Type::displacement ? bc.value[c] : 0.0);
      continue;
    }
    typename SolverDeck<dim>::SurfaceLoad load;
    load.region = static_cast<int>(i);
    load.is_pressure = bc.type == BoundaryConditionSpec::Type::pressure;
    if (load.is_pressure)
      load.pressure = bc.value[0];
    else
      for (int c = 0; c < dim; ++c) load.traction[c] = bc.value[c];
    // Consistent nodal forces of a constant traction (a neo-Hookean deck's pressure: −p n on the
    // reference face): ∫ N_k t ds over each face.
    if (!load.is_pressure || deck.neo_hookean)
      for (const auto& f : set.faces) {
        const Vec<dim> t =
            load.is_pressure ? Vec<dim>(-load.pressure * outward_normal(deck, f)) : load.traction;
        const double m = face_measure(deck, f);
        const std::vector<long> fn = deck.face_nodes(f);
        for (std::size_t k = 0; k < fn.size(); ++k) {
          const bool corner = static_cast<int>(k) < dim;
          const double w = deck.degree == 1 ? 1.0 / dim
                           : dim == 3       ? (corner ? 0.0 : 1.0 / 3.0)
                                            : (corner ? 1.0 / 6.0 : 2.0 / 3.0);
          if (w == 0.0) continue;
          force.try_emplace(fn[k], Vec<dim>::Zero()).first->second += w * m * t;
        }
      }
    deck.surface_loads.push_back(load);
  }
  for (const auto& [key, value] : held) deck.held.push_back({key.first, key.second, value});
  for (const auto& [node, f] : force) deck.nodal_forces.emplace_back(node, f);
  for (const auto& needle : sc.needles)
    deck.not_expressed.push_back("the insertion of needle '" + needle.name +
                                 "': this deck holds step 0, the state under the boundary conditions alone");
}

}  // namespace

template <int dim>
SolverDeck<dim> solver_deck(const MeshModel<dim>& model, const SimplexMesh<dim>& world,
                            const std::vector<double>& modulus, double poisson_ratio, unsigned degree,
                            const Scenario* scenario) {
  if (degree < 1 || degree > 2) throw std::invalid_argument("solver deck: degree must be 1 or 2");
  if (modulus.size() != model.mesh.n_cells())
    throw std::invalid_argument("solver deck: one modulus per cell needed");
  SolverDeck<dim> deck;
  deck.degree = degree;
  deck.modulus = modulus;
  if (model.label.size() == model.mesh.n_cells()) {
    deck.label = model.label;
    deck.label_name = model.label_name;
  }
  deck.poisson_ratio = poisson_ratio;
  deck.neo_hookean = scenario && scenario->material_model == Scenario::MaterialModel::neo_hookean;
  if (world.n_points() != model.mesh.n_points() || world.n_cells() != model.mesh.n_cells())
    throw std::invalid_argument("solver deck: the world mesh is not the model's mesh");
  deck.n_vertices = world.n_points();
  deck.nodes = world.points;
  std::vector<Vec<dim>> frame_nodes = model.mesh.points;
  for (const auto& c : world.cells) deck.cells.emplace_back(c.begin(), c.end());
  if (degree == 2) {
    const QuadraticCells<dim> q = quadratic_cells<dim>(world.cells, world.n_points());
    deck.edges = q.edges;
    for (const auto& [a, b] : q.edges) {
      deck.nodes.push_back(0.5 * (world.points[a] + world.points[b]));
      frame_nodes.push_back(0.5 * (model.mesh.points[a] + model.mesh.points[b]));
    }
    for (std::size_t c = 0; c < q.cells.size(); ++c)
      deck.cells[c].assign(q.cells[c].begin(), q.cells[c].end());
  }
  Vec<dim> box_min = model.mesh.points.at(0), box_max = box_min;
  for (const auto& p : model.mesh.points) box_min = box_min.cwiseMin(p), box_max = box_max.cwiseMax(p);
  const auto boundary = boundary_faces(world);
  for (int a = 0; a < dim; ++a)
    for (bool upper : {false, true}) {
      RegionSpec face;
      face.axis = a;
      face.upper = upper;
      face.face = std::string(axis_names[a]) + (upper ? "_max" : "_min");
      deck.box_faces.push_back(region_set(deck, frame_nodes, boundary,
                                          scenario_region<dim>(face, box_min, box_max, model.transform),
                                          face.face));
      deck.box_faces.back().description = "image box face " + face.face;
    }
  if (scenario)
    add_conditions(deck, *scenario, frame_nodes, boundary, box_min, box_max, model.transform,
                   model.label_image.get());
  return deck;
}

template const std::array<int, 2>& deck_face_corners<2>(int);
template const std::array<int, 3>& deck_face_corners<3>(int);
template struct SolverDeck<2>;
template struct SolverDeck<3>;
template SolverDeck<2> solver_deck<2>(const MeshModel<2>&, const SimplexMesh<2>&, const std::vector<double>&,
                                      double, unsigned, const Scenario*);
template SolverDeck<3> solver_deck<3>(const MeshModel<3>&, const SimplexMesh<3>&, const std::vector<double>&,
                                      double, unsigned, const Scenario*);

}  // namespace vim::pipeline

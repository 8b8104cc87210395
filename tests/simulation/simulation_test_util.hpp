// Shared set-up of the needle-simulation tests: the axis-symmetric block mesh, scenario text,
// quiet options and small field helpers (test code only).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <vector>
#include <vim/image.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/scenario/scenario.hpp>
#include <vim/pipeline/simulation/simulation.hpp>
#include <vim/voxel_statistics.hpp>

namespace vim::pipeline::simulation_test {

using V3 = Eigen::Vector3d;

// A block meshed with the Kuhn grid (frame coordinates), element means from E(centroid).
inline MeshModel<3> block(const V3& lo, const V3& hi, const std::array<int, 3>& n,
                          const std::function<double(const V3&)>& E) {
  MeshModel<3> m;
  m.mesh = regular_grid_mesh<3>(lo, hi, n);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) {
    ElementValue v;
    v.voxels = 1;
    v.mean = E(centroid<3>(cell_points(m.mesh, c)));
    m.values.push_back(v);
  }
  return m;
}

// Block [-w,w]x[-w,w]x[0,length] (default w = 6, length 24: 7x7x13 nodes), needle along +z on the axis
// x = y = 0: the Kuhn grid of the quadrant [0,w]x[0,w]x[0,length] with `quadrant` nodes per axis mirrored
// into the four quadrants, so that the mesh (and the problem) is exactly symmetric under x -> -x,
// y -> -y and x <-> y.
inline MeshModel<3> axis_block(double E = 10.0, double w = 6.0, double length = 24.0,
                               const std::array<int, 3>& quadrant = {{4, 4, 13}}) {
  const SimplexMesh<3> q = regular_grid_mesh<3>(V3(0, 0, 0), V3(w, w, length), quadrant);
  MeshModel<3> m;
  std::map<std::tuple<long, long, long>, int> ids;
  auto id = [&](const V3& p) {
    const auto key =
        std::make_tuple(std::lround(p[0] * 1e6), std::lround(p[1] * 1e6), std::lround(p[2] * 1e6));
    const auto it = ids.find(key);
    if (it != ids.end()) return it->second;
    m.mesh.points.push_back(p);
    return ids[key] = static_cast<int>(m.mesh.points.size() - 1);
  };
  for (const double sx : {1.0, -1.0})
    for (const double sy : {1.0, -1.0})
      for (const auto& c : q.cells) {
        SimplexMesh<3>::Cell cell;
        for (int k = 0; k < 4; ++k)
          cell[k] = id(V3(sx * q.points[c[k]][0], sy * q.points[c[k]][1], q.points[c[k]][2]));
        m.mesh.cells.push_back(cell);
      }
  orient_positively(m.mesh);
  m.values.assign(m.mesh.n_cells(), ElementValue{1, E, 0.0});
  return m;
}

inline std::string yaml(const std::string& needle, const std::string& targets = "[]",
                        const std::string& material = "{}",
                        const std::string& bcs = "[{type: fixed, region: {box_face: z_max}}]") {
  return "material: " + material + "\nboundary_conditions: " + bcs + "\nneedle: " + needle +
         "\ntargets: " + targets + "\n";
}

inline const std::string kStick =
    "{entry: [0, 0, 0], direction: [0, 0, 1], depth: 12, steps: 6, diameter: 1, friction: {model: stick}}";

// The message of the ScenarioError a scenario text (3D, file name plan.yaml) is refused with, or "no error".
inline std::string procedure_parse_error(const std::string& text) {
  try {
    parse_scenario_text(text, 3, "plan.yaml");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "no error";
}

inline SimulationOptions quiet() {
  SimulationOptions o;
  o.progress = false;
  return o;
}

// The warnings of a run other than the small-strain ones (the largest strain in the model above 10%,
// which stuck needles reach on these coarse test meshes; the shaft's near field) and the band's (targets
// or modulus changes inside it): the tests of the other warnings count these.
template <int dim>
std::vector<std::string> other_warnings(const SimulationResult<dim>& result) {
  std::vector<std::string> out;
  for (const auto& w : result.warnings)
    if (w.find("the limit of small-strain elasticity") == std::string::npos &&
        w.find("next to the shaft the strain exceeds") == std::string::npos &&
        w.find("inside the band (radius") == std::string::npos)
      out.push_back(w);
  return out;
}

// quiet(), writing the output files below `dir` (emptied first).
inline SimulationOptions writing_into(const std::filesystem::path& dir) {
  std::filesystem::remove_all(dir);
  SimulationOptions o = quiet();
  o.output_file = [dir](const std::string& rel) {
    const std::filesystem::path p = dir / rel;
    std::filesystem::create_directories(p.parent_path());
    return p;
  };
  return o;
}

inline std::map<std::tuple<long, long, long>, std::size_t> vertex_index(const std::vector<V3>& pts) {
  std::map<std::tuple<long, long, long>, std::size_t> m;
  for (std::size_t i = 0; i < pts.size(); ++i)
    m[{std::lround(pts[i][0] * 1000), std::lround(pts[i][1] * 1000), std::lround(pts[i][2] * 1000)}] = i;
  return m;
}

inline double max_norm(const std::vector<V3>& u) {
  double m = 0.0;
  for (const auto& x : u) m = std::max(m, x.norm());
  return m;
}

// A block image of `n` voxels of 1 mm, a stiffer sphere at its centre (or uniform).
inline Image<3> block_image(const std::array<long, 3>& n, double inclusion_modulus) {
  Image<3> img(n, {{1, 1, 1}}, {{0.5, 0.5, 0.5}});
  const V3 c(0.5 * n[0], 0.5 * n[1], 0.5 * n[2]);
  for (std::size_t v = 0; v < img.voxel_count(); ++v) {
    const auto i = img.index_of(v);
    const V3 x(i[0] + 1.0, i[1] + 1.0, i[2] + 1.0);
    img.data[v] = static_cast<float>((x - c).norm() < 4.0 ? inclusion_modulus : 20.0);
  }
  return img;
}

inline MeshModel<3> image_mesh(const Image<3>& img, const SimplexMesh<3>& mesh) {
  MeshModel<3> m;
  m.mesh = mesh;
  const VoxelStatistics<3> stats(img);
  for (std::size_t c = 0; c < m.mesh.n_cells(); ++c) m.values.push_back(stats.value(cell_points(m.mesh, c)));
  return m;
}

// The block image's needle scenario: the path along z off the mesh vertices, the bottom face held.
inline Scenario block_scenario(const std::string& needle_extra) {
  return parse_scenario_text(
      yaml("{entry: [9.37, 10.29, 0], direction: [0, 0, 1], depth: 18, steps: 12, diameter: 1.27" +
               needle_extra + "}",
           "[]", "{youngs_modulus: image, poisson_ratio: 0.45}",
           "[{type: fixed, region: {box_face: z_max}}, {type: fixed, region: {box_face: x_min}}]"),
      3);
}

}  // namespace vim::pipeline::simulation_test

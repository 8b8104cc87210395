// The world-coordinate grids that mesh.vtu, the exports and the simulation steps share
// (vtk_output.hpp): the voxel grid against the FEM voxel model's own vertices (deal.II's numbering, which
// fem checks against subdivided_hyper_rectangle) and against the voxel box computed by hand; the grid of
// a world mesh against the grid of the frame mesh with the transform applied, on a mirroring image;
// PipelineRun called stage by stage: the world grid is the mesh transformed, and the files appear only
// at the writing stages.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vim/fem/elasticity.hpp>
#include <vim/initial_mesh.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/output/exports.hpp>
#include <vim/pipeline/output/vtk_output.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;

namespace {

// A rotation about z by 30 degrees followed by a mirror of y (det = −1).
WorldTransform<3> mirrored_rotation(const Eigen::Vector3d& origin) {
  const double pi = std::acos(-1.0), c = std::cos(pi / 6), s = std::sin(pi / 6);
  WorldTransform<3> t;
  t.origin = origin;
  t.direction << c, -s, 0, -s, -c, 0, 0, 0, 1;
  return t;
}

Eigen::Vector3d point(const UnstructuredGrid& g, long i) {
  const auto& p = g.points[static_cast<std::size_t>(i)];
  return {p[0], p[1], p[2]};
}

}  // namespace

TEST(WorldGrid, VoxelGridHasTheVoxelModelsVerticesAndOneHexPerVoxel) {
  Image<3> image({{4, 3, 2}}, {{0.5, 1.0, 2.0}}, {{10.0, -3.0, 1.0}}, 1.0f);
  const WorldTransform<3> tf = mirrored_rotation(Eigen::Vector3d(10.0, -3.0, 1.0));
  const UnstructuredGrid g = voxel_grid<3>(image, tf);
  const auto model = fem::ElasticModel<3>::voxel_grid(image.size, image.box_min(), image.box_max(),
                                                      std::vector<double>(24, 1.0), 0.3);
  ASSERT_EQ(g.points.size(), model.vertices().size());
  for (std::size_t v = 0; v < g.points.size(); ++v)
    EXPECT_LT((point(g, static_cast<long>(v)) - tf.to_world(model.vertices()[v])).norm(), 1e-12);
  ASSERT_EQ(g.n_cells(), 24u);
  EXPECT_EQ(g.vtk_cell_type, 12);
  for (std::size_t k = 0; k < 24; ++k) {
    // Voxel k's corners: its centre ± half the spacing along each axis (hand-computed box), and a
    // positively oriented hexahedron in the world (VTK order: the first face counter-clockwise seen
    // from the second).
    const auto idx = image.index_of(k);
    Eigen::Vector3d lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = image.origin[a] + (idx[a] - 0.5) * image.spacing[a];
      hi[a] = lo[a] + image.spacing[a];
    }
    const long* c = &g.connectivity[8 * k];
    for (int n = 0; n < 8; ++n) {
      const Eigen::Vector3d f = tf.to_frame(point(g, c[n]));
      for (int a = 0; a < 3; ++a)
        EXPECT_TRUE(std::abs(f[a] - lo[a]) < 1e-12 || std::abs(f[a] - hi[a]) < 1e-12) << "voxel " << k;
    }
    const Eigen::Vector3d e1 = point(g, c[1]) - point(g, c[0]), e3 = point(g, c[3]) - point(g, c[0]),
                          e4 = point(g, c[4]) - point(g, c[0]);
    EXPECT_NEAR(e1.cross(e3).dot(e4), 0.5 * 1.0 * 2.0, 1e-12) << "voxel " << k;
  }
}

TEST(WorldGrid, GridOfTheWorldMeshIsTheFrameMeshTransformed) {
  MeshModel<3> model;
  model.mesh = regular_grid_mesh<3>(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 3, 1), {{3, 4, 2}});
  model.transform = mirrored_rotation(Eigen::Vector3d(0.5, 0.5, 0.5));
  const UnstructuredGrid a = simplex_grid<3>(world_mesh<3>(model));
  const UnstructuredGrid b = simplex_grid<3>(model.mesh, model.transform);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t v = 0; v < a.points.size(); ++v)
    for (int d = 0; d < 3; ++d) EXPECT_DOUBLE_EQ(a.points[v][d], b.points[v][d]);
  EXPECT_EQ(a.connectivity, b.connectivity);
  // Positive in the world: the mirror swapped the first two vertices of every cell.
  for (std::size_t c = 0; c < a.n_cells(); ++c) {
    const long* t = &a.connectivity[4 * c];
    const Eigen::Vector3d p0 = point(a, t[0]);
    EXPECT_GT((point(a, t[1]) - p0).cross(point(a, t[2]) - p0).dot(point(a, t[3]) - p0), 0.0);
  }
}

TEST(PipelineRun, StagesOneByOne) {
  vim::test::TempDir dir("meshing_run");
  const Verbosity verbosity = Log::verbosity();
  Log::set_verbosity(Verbosity::quiet);
  OrientedImage<2> image = phantoms::two_circles(40);
  const double c = std::cos(0.3), s = std::sin(0.3);
  image.direction << c, -s, s, c;  // an oblique image: the world grid is rotated
  const std::string file = (dir.path / "circles.mha").string();
  write_image(image, file);
  RunOptions o;
  o.image = file;
  o.out = dir.path / "out";
  o.nodes = 60;
  o.max_iterations = 3;
  o.exports = {"msh"};
  o.verbosity = Verbosity::quiet;
  PipelineRun<2> run(o, ImageFile(file));
  run.read_inputs();
  run.make_mesh();
  const auto& mesh = run.model().mesh;
  const UnstructuredGrid& grid = run.world_grid();
  ASSERT_EQ(grid.points.size(), mesh.n_points());
  ASSERT_EQ(grid.n_cells(), mesh.n_cells());
  for (std::size_t v = 0; v < mesh.n_points(); ++v) {
    const Eigen::Vector2d w = image.to_world(mesh.points[v]);
    EXPECT_NEAR(grid.points[v][0], w[0], 1e-12);
    EXPECT_NEAR(grid.points[v][1], w[1], 1e-12);
  }
  EXPECT_EQ(run.report()["mesh"]["nodes"].get<std::size_t>(), mesh.n_points());
  EXPECT_FALSE(std::filesystem::exists(o.out / "mesh.vtu"));
  run.build_model();
  run.simulate();
  run.write_outputs();
  EXPECT_TRUE(std::filesystem::exists(o.out / "mesh.vtu"));
  EXPECT_TRUE(std::filesystem::exists(o.out / "mesh.msh"));
  EXPECT_FALSE(std::filesystem::exists(o.out / "report.json"));
  run.write_report();
  EXPECT_TRUE(std::filesystem::exists(o.out / "report.json"));
  Log::set_verbosity(verbosity);
}

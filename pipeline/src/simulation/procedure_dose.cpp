// The dose of a procedure's seeds (procedure_dose.hpp).
#include "simulation/procedure_dose.hpp"

#include <cmath>
#include <stdexcept>
#include <vim/pipeline/dose/dose_volume.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/scenario/scenario_regions.hpp>

namespace vim::pipeline {

template <int dim>
nlohmann::json procedure_dose(const SimulationContext<dim>& ctx, const std::vector<NeedleRun<dim>>& needles) {
  if constexpr (dim != 3) {
    throw std::logic_error("procedure_dose: the TG-43 dose is 3D");
  } else {
    const DoseSpec& spec = *ctx.sc.dose;
    const dose::SeedModel& model = dose::seed_model(spec.seed_model);
    std::vector<dose::Point> planned, final_positions;
    for (const auto& r : needles)
      for (const auto& seed : r.seeds) {
        const Eigen::Vector3d f = seed.final_position();
        planned.push_back({{seed.planned[0], seed.planned[1], seed.planned[2]}});
        final_positions.push_back({{f[0], f[1], f[2]}});
      }
    // The grid: cells of spacing h over the frame box, a point at each centre.
    const double h = spec.grid;
    std::array<long, 3> n{};
    for (int a = 0; a < 3; ++a)
      n[a] = std::max(1L, std::lround(std::floor((ctx.box_max[a] - ctx.box_min[a]) / h)));
    const Eigen::Vector3d first = ctx.box_min + Eigen::Vector3d::Constant(0.5 * h);
    const Eigen::Vector3d first_world = ctx.tf.to_world(first);
    OrientedImage<3> images[2];
    for (auto& im : images) {
      im.image = Image<3>(n, {{h, h, h}}, {{first_world[0], first_world[1], first_world[2]}});
      im.direction = ctx.tf.direction;
    }
    const fem::Region<3> region =
        scenario_region<3>(spec.region, ctx.box_min, ctx.box_max, ctx.tf, ctx.label_image.get());
    std::vector<double> in_planned, in_final;
    for (std::size_t v = 0; v < images[0].image.voxel_count(); ++v) {
      const auto i = images[0].image.index_of(v);
      const Eigen::Vector3d x = first + h * Eigen::Vector3d(double(i[0]), double(i[1]), double(i[2]));
      const Eigen::Vector3d w = ctx.tf.to_world(x);
      const dose::Point p{{w[0], w[1], w[2]}};
      const double dp = dose::seeds_dose_gy(model, spec.air_kerma_strength, planned, p);
      const double df = dose::seeds_dose_gy(model, spec.air_kerma_strength, final_positions, p);
      images[0].image.data[v] = static_cast<float>(dp);
      images[1].image.data[v] = static_cast<float>(df);
      if (region.contains(x)) in_planned.push_back(dp), in_final.push_back(df);
    }
    if (in_planned.empty())
      throw ScenarioError(ctx.sc.where(spec.line) + "dose.region " + spec.region.describe() +
                          " holds no point of the dose grid (spacing " + std::to_string(h) +
                          "); use a larger region or a finer grid");
    const auto metrics = [&](const std::vector<double>& d) {
      const dose::DoseVolumeMetrics m = dose::dose_volume_metrics(d, spec.prescription);
      return nlohmann::json{
          {"d90_gy", m.d90_gy}, {"v100_percent", m.v100_percent}, {"v150_percent", m.v150_percent}};
    };
    nlohmann::json rep = {{"seed_model", model.name},
                          {"air_kerma_strength", spec.air_kerma_strength},
                          {"prescription_gy", spec.prescription},
                          {"grid", h},
                          {"grid_size", n},
                          {"region_points", in_planned.size()},
                          {"seeds", planned.size()},
                          {"planned", metrics(in_planned)},
                          {"final", metrics(in_final)}};
    if (ctx.opt.output_file) {
      write_image<3>(images[0], ctx.opt.output_file("dose_planned.mha").string());
      write_image<3>(images[1], ctx.opt.output_file("dose_final.mha").string());
      rep["files"] = {"dose_planned.mha", "dose_final.mha"};
    }
    return rep;
  }
}

template nlohmann::json procedure_dose<2>(const SimulationContext<2>&, const std::vector<NeedleRun<2>>&);
template nlohmann::json procedure_dose<3>(const SimulationContext<3>&, const std::vector<NeedleRun<3>>&);

}  // namespace vim::pipeline

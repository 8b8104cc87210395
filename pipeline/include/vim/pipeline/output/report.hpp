// The pieces of report.json and the end-of-run text summary. PipelineRun makes the report once, at the
// end, from the results of its stages (run_write_report.cpp); the README documents every field. Units:
// lengths in the image's unit, values (moduli) in the image's unit, angles in degrees, times in seconds.
#pragma once

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/quality.hpp>
#include <vim/vim.hpp>

namespace vim::pipeline {

struct ImageSummary {
  double min = 0.0, max = 0.0, mean = 0.0, stddev = 0.0;
  std::size_t voxels = 0;
};
template <int dim>
ImageSummary summarize(const Image<dim>& image);

// {"file", "dimension", "size", "spacing", "origin", "direction" (row-major), "world_bounds"
// {"min","max"} of the voxel box corners in world coordinates, "values" {min,max,mean,stddev}}.
template <int dim>
nlohmann::json image_json(const OrientedImage<dim>& image, const std::string& file);

// {"min_dihedral_deg","max_dihedral_deg","min_nrr","inverted"}: in 2D the "dihedral" angles are the
// triangles' interior angles.
nlohmann::json quality_json(const MeshQuality& quality);

// [{"iteration","E","E_G","E_D","v","moves","swaps","seconds"}, ...]
nlohmann::json history_json(const std::vector<IterationRecord>& history);

// Human-readable lines for `--info` and the demo: size, spacing, extent, value statistics.
void print_image_info(std::ostream& out, const nlohmann::json& image);

// One-screen summary of a finished run, built from the report (other stages' keys included).
void print_summary(std::ostream& out, const nlohmann::json& report);

// A stage's wall time, listed under its name in report.json's "timing".
struct StageTime {
  std::string stage;
  double seconds = 0.0;
};

// Times a stage from its construction; stop() appends {stage, seconds} to `times` and returns the seconds.
class StageTimer {
 public:
  StageTimer(std::vector<StageTime>& times, std::string stage);
  double stop();

 private:
  std::vector<StageTime>& times_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace vim::pipeline

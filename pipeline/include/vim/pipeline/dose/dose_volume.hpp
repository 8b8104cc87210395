// The dose of a set of permanent seeds at points and the dose-volume metrics of a region sampled by
// points of equal volume (a grid): D90, V100 and V150 (AAPM TG-137, Nath et al., Med. Phys. 36(11),
// 2009: the prostate implant's reported quantities; docs/dose.md).
#pragma once

#include <array>
#include <vector>
#include <vim/pipeline/dose/tg43.hpp>

namespace vim::pipeline::dose {

using Point = std::array<double, 3>;  // mm

// The total dose in Gy at `point` of seeds of one model and strength at `seeds` (mm; the sum of
// their point-source doses, total_dose_gy, at the distances converted to cm).
double seeds_dose_gy(const SeedModel& model, double air_kerma_strength, const std::vector<Point>& seeds,
                     const Point& point);

struct DoseVolumeMetrics {
  double d90_gy = 0;        // the largest dose that at least 90% of the region's volume receives
  double v100_percent = 0;  // the share of the volume that receives at least the prescription dose
  double v150_percent = 0;  // ... at least 1.5 times the prescription dose
};

// The metrics of a region sampled by points of equal volume, from their doses (Gy). Empty doses throw
// std::invalid_argument.
DoseVolumeMetrics dose_volume_metrics(std::vector<double> doses, double prescription_gy);

}  // namespace vim::pipeline::dose

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <vim/pipeline/dose/dose_volume.hpp>

namespace vim::pipeline::dose {

double seeds_dose_gy(const SeedModel& model, double air_kerma_strength, const std::vector<Point>& seeds,
                     const Point& point) {
  double dose = 0;
  for (const Point& s : seeds) {
    const double dx = point[0] - s[0], dy = point[1] - s[1], dz = point[2] - s[2];
    dose += total_dose_gy(model, air_kerma_strength, std::sqrt(dx * dx + dy * dy + dz * dz) / 10.0);
  }
  return dose;
}

DoseVolumeMetrics dose_volume_metrics(std::vector<double> doses, double prescription_gy) {
  if (doses.empty()) throw std::invalid_argument("dose_volume_metrics: the region holds no point");
  std::sort(doses.begin(), doses.end(), std::greater<>());
  const std::size_t n = doses.size();
  // The hottest ceil(0.9 n) points hold at least 90% of the volume; the coldest of them is D90.
  const auto k = static_cast<std::size_t>(std::ceil(0.9 * static_cast<double>(n)));
  const auto share_at_least = [&](double level) {
    const auto count = std::upper_bound(doses.begin(), doses.end(), level, std::greater<>()) - doses.begin();
    // upper_bound with greater<>: the first dose < level, so [begin, it) are the doses >= level.
    return 100.0 * static_cast<double>(count) / static_cast<double>(n);
  };
  DoseVolumeMetrics m;
  m.d90_gy = doses[std::max<std::size_t>(k, 1) - 1];
  m.v100_percent = share_at_least(prescription_gy);
  m.v150_percent = share_at_least(1.5 * prescription_gy);
  return m;
}

}  // namespace vim::pipeline::dose

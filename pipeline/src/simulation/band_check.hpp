// Private to the simulation sources: what lies inside the needle's bands (docs/needle-model.md,
// "What lies inside a band"). Within a station's band radius R of the axis the model holds only the
// band's mean and replaces the tissue by a homogeneous annulus of the modulus at the station's centre:
// a target there is read through that annulus, and a change of the modulus there is not seen by the
// station's compliance. Both are reported (report.json "band") and warned about.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace vim::pipeline {

// A relative difference of the modulus within a band from the modulus at its station's centre above
// this is a modulus change inside the band.
inline constexpr double kBandModulusChange = 0.2;

struct BandModulusChange {
  double from = 0.0, to = 0.0;  // arc length along the path of the station's segment
  double change = 0.0;          // the largest |E − E_centre| / E_centre over the band's samples
};

struct BandCheck {
  std::vector<int> target_inside;  // per target: 1 within R of the axis along the stations' span
  std::vector<BandModulusChange> modulus_changes;
};

// The stations (centres s_j, lengths ℓ_j along the path from `entry` along the unit `axis`), their band
// radius R, the targets (same frame) and the modulus at a point (≤ 0 outside the model). The modulus is
// sampled on 3 rings (R/3, 2R/3, R) of 16 points at 3 cross-sections of each station, and at its centre.
inline BandCheck check_bands(const Eigen::Vector3d& entry, const Eigen::Vector3d& axis, double radius,
                             const std::vector<double>& centre, const std::vector<double>& length,
                             const std::vector<Eigen::Vector3d>& targets,
                             const std::function<double(const Eigen::Vector3d&)>& modulus) {
  constexpr double pi = 3.14159265358979323846;
  BandCheck out;
  if (centre.empty() || !(radius > 0.0)) {
    out.target_inside.assign(targets.size(), 0);
    return out;
  }
  const double lo = centre.front() - 0.5 * length.front(), hi = centre.back() + 0.5 * length.back();
  for (const auto& x : targets) {
    const Eigen::Vector3d d = x - entry;
    const double s = d.dot(axis);
    out.target_inside.push_back(s >= lo && s <= hi && (d - s * axis).norm() < radius ? 1 : 0);
  }
  Eigen::Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  for (std::size_t j = 0; j < centre.size(); ++j) {
    const double e0 = modulus(entry + centre[j] * axis);
    if (!(e0 > 0.0)) continue;
    double change = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double s = centre[j] + (a - 1) * length[j] / 3.0;
      for (int r = 1; r <= 3; ++r)
        for (int k = 0; k < 16; ++k) {
          const double t = 2.0 * pi * k / 16.0, rr = radius * r / 3.0;
          const double e = modulus(entry + s * axis + rr * (std::cos(t) * e1 + std::sin(t) * e2));
          if (e > 0.0) change = std::max(change, std::abs(e - e0) / e0);
        }
    }
    if (change > kBandModulusChange)
      out.modulus_changes.push_back({centre[j] - 0.5 * length[j], centre[j] + 0.5 * length[j], change});
  }
  return out;
}

// The run summary's warning ("" when nothing lies inside a band).
inline std::string band_warning(const std::string& where, const std::string& who, double radius,
                                const std::vector<std::string>& target_names, const BandCheck& check) {
  std::string inside;
  for (std::size_t t = 0; t < target_names.size() && t < check.target_inside.size(); ++t)
    if (check.target_inside[t]) inside += (inside.empty() ? "" : ", ") + target_names[t];
  if (inside.empty() && check.modulus_changes.empty()) return "";
  std::ostringstream w;
  w << where << who << ": inside the band (radius " << radius
    << " around the shaft, where the model holds only a band mean and an annulus of one modulus; "
       "docs/needle-model.md) lie ";
  if (!inside.empty()) w << "targets: " << inside;
  if (!check.modulus_changes.empty()) {
    const auto peak = std::max_element(
        check.modulus_changes.begin(), check.modulus_changes.end(),
        [](const BandModulusChange& a, const BandModulusChange& b) { return a.change < b.change; });
    w << (inside.empty() ? "" : "; ") << "modulus changes above " << 100.0 * kBandModulusChange << "% at "
      << check.modulus_changes.size() << " stations (largest " << 100.0 * peak->change
      << "% between path lengths " << peak->from << " and " << peak->to << ")";
  }
  w << "; refine the mesh near the path (mesh.needle_refinement) or set a smaller needle.coupling_radius";
  return w.str();
}

}  // namespace vim::pipeline

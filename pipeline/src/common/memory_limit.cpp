// The memory estimate of a meshing run and the memory available to the process (memory_limit.hpp).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/common/memory_limit.hpp>

namespace vim::pipeline {

double estimated_peak_bytes(double voxels, double nodes) {
  return MemoryModel::base_bytes + MemoryModel::bytes_per_voxel * voxels +
         MemoryModel::bytes_per_node * nodes;
}

namespace {

// The first number of a one-line file ("max" or unreadable: nullopt).
std::optional<double> read_number(const char* path) {
  std::ifstream in(path);
  double v = 0;
  if (in >> v) return v;
  return std::nullopt;
}

std::optional<double> mem_available() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024.0;
  return std::nullopt;
}

}  // namespace

std::optional<double> available_memory_bytes() {
  std::optional<double> avail = mem_available();
  const auto max = read_number("/sys/fs/cgroup/memory.max");
  if (max) {
    const double left = *max - read_number("/sys/fs/cgroup/memory.current").value_or(0.0);
    avail = avail ? std::min(*avail, left) : left;
  }
  return avail;
}

std::optional<double> parse_memory_size(const std::string& text) {
  std::istringstream in(text);
  double v = 0;
  if (!(in >> v) || !std::isfinite(v) || !(v > 0)) return std::nullopt;
  std::string suffix;
  in >> suffix;
  if (!in.eof()) return std::nullopt;
  const std::string units = "kMGT";
  if (suffix.empty()) return v;
  const auto p = units.find(suffix == "K" ? 'k' : suffix[0]);
  if (suffix.size() > 2 || p == std::string::npos || (suffix.size() == 2 && suffix[1] != 'B'))
    return std::nullopt;
  return v * std::pow(1024.0, static_cast<double>(p + 1));
}

std::string format_bytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GB", bytes / 1e9);
  return buf;
}

void check_memory_fits(double voxels, double nodes, double limit) {
  const bool automatic = !(limit > 0.0);
  if (automatic) {
    const auto avail = available_memory_bytes();
    if (!avail) return;
    limit = *avail;
  }
  const double need = estimated_peak_bytes(voxels, nodes);
  if (need <= limit) return;
  std::ostringstream m;
  m.precision(3);
  m << "estimated peak memory " << format_bytes(need) << " (" << voxels << " voxels at "
    << MemoryModel::bytes_per_voxel << " B, " << nodes << " nodes at " << MemoryModel::bytes_per_node
    << " B, libraries " << format_bytes(MemoryModel::base_bytes) << ") exceeds "
    << (automatic ? "the memory available to the process, " : "--max-memory ") << format_bytes(limit)
    << "; use a smaller image, fewer --nodes or a larger --spacing"
    << (automatic ? ", or set --max-memory if the estimate is too cautious" : ", or raise --max-memory");
  throw InputError(m.str());
}

}  // namespace vim::pipeline

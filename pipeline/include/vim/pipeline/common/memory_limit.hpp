// Peak memory of a meshing run, estimated before meshing from its voxel and node counts, and the
// memory the process may use (--max-memory; default: MemAvailable and the cgroup limit). The
// coefficients are measured peak RSS (docs/reliability.md, "Memory"); the FEM simulation is not
// included.
#pragma once

#include <optional>
#include <string>

namespace vim::pipeline {

struct MemoryModel {
  static constexpr double base_bytes = 200e6;  // the loaded libraries (deal.II, ITK, VTK, TBB)
  // Float image 4, prefix sums 16, read copy 4, and about 2 more measured between 256³ and 512³
  // (26.1 B per voxel); 27 keeps the estimate above every measured peak.
  static constexpr double bytes_per_voxel = 27.0;
  static constexpr double bytes_per_node = 1600.0;  // mesh, adjacency, caches, outputs
};

// Estimated peak bytes of meshing `voxels` image voxels (IMAGE plus any sizing image) into `nodes`.
double estimated_peak_bytes(double voxels, double nodes);

// The bytes this process may still use: the smaller of /proc/meminfo MemAvailable and the cgroup v2
// limit (memory.max - memory.current) when there is one; nullopt if neither can be read.
std::optional<double> available_memory_bytes();

// "8G", "512M", "100k", "123456" (bytes; suffixes k, M, G, T powers of 1024) -> bytes; nullopt for
// anything else (negative, zero, not a number, unknown suffix).
std::optional<double> parse_memory_size(const std::string& text);

// "1.23 GB"-style text of a byte count.
std::string format_bytes(double bytes);

// Throws InputError when the estimate exceeds `limit` bytes (0 = available_memory_bytes(), no check if
// unknown): the message gives the estimate, its parts and the limit's source.
void check_memory_fits(double voxels, double nodes, double limit);

}  // namespace vim::pipeline

#!/usr/bin/env bash
# Performance benchmarks (docs/performance.md), all ratios measured in this one invocation (never asserted):
#   - voxel enclosure: prefix sums vs brute-force per-voxel test, per element size;
#   - one VIM iteration at 343 and 4096 nodes, 1 vs 2 threads;
#   - a full converged VIM run at 4096 nodes (wall time, iterations, TF%) via table1, with the
#     default screened node update and with every direction searched in full (--search-width 0);
#   - optionally VIM vs CGAL Mesh_3 at the same node count (bench_cgal_mesh3, -DVIM_WITH_CGAL=ON).
# Usage: bench/run.sh [build-dir]   (default: ./build). Builds the targets it needs.
set -euo pipefail
BUILD=${1:-build}
SRC=$(cd "$(dirname "$0")/.." && pwd)
cmake -S "$SRC" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD" -j"${JOBS:-2}" --target bench_mesher_enclosure bench_mesher_iteration table1 >/dev/null
echo "# vim-pipeline benchmarks — commit $(git -C "$SRC" rev-parse --short HEAD 2>/dev/null || echo unknown)," \
     "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores, $(date -u +%F)"
echo
"$BUILD/bench/bench_mesher_enclosure"
echo
"$BUILD/bench/bench_mesher_iteration" 343 4096
echo
echo "Full converged run at 4096 nodes (grid row: the starting mesh):"
/usr/bin/time -f "peak memory (VmHWM-equivalent max RSS): %M kB" "$BUILD/bench/table1" 4096
echo
echo "The same with every node-update direction searched in full (--search-width 0):"
"$BUILD/bench/table1" --search-width 0 4096
# Optional CGAL Mesh_3 side-by-side (same image, same node count): only when the build was configured
# with -DVIM_WITH_CGAL=ON and CGAL was found, so the binary exists (the target is absent otherwise).
cmake --build "$BUILD" -j"${JOBS:-2}" --target bench_cgal_mesh3 >/dev/null 2>&1 || true
if [ -x "$BUILD/bench/bench_cgal_mesh3" ]; then
  echo
  echo "VIM (all cores) vs CGAL Mesh_3 (sequential) at 4096 nodes (docs/cgal_comparison.md):"
  "$BUILD/bench/bench_cgal_mesh3" --nodes 4096 --match-tf
  echo
  echo "Both sequential: VIM --threads 1 vs CGAL Mesh_3 at 4096 nodes:"
  "$BUILD/bench/bench_cgal_mesh3" --nodes 4096 --threads 1
elif ! dpkg -s libcgal-dev >/dev/null 2>&1; then
  echo
  echo "CGAL Mesh_3 comparison skipped: libcgal-dev is not installed (optional dependency of bench/ only)."
else
  echo
  echo "CGAL Mesh_3 comparison skipped: configure with -DVIM_WITH_CGAL=ON and build bench_cgal_mesh3."
fi

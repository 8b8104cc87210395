#!/usr/bin/env bash
# README command 2: install dependencies, build, and run every test (CTest; labels unit,
# integration, validation, mpi). Exits non-zero on any failure.
# Pass ctest arguments to select a subset, e.g. `scripts/test.sh -L unit`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-$ROOT/build}"
start=$(date +%s)
bash "$ROOT/scripts/setup-deps.sh"
# Source checks first: .clang-format and the size limits (files <= 700 lines, functions <= 150).
bash "$ROOT/scripts/check-format.sh"
/usr/bin/python3 "$ROOT/scripts/check-size.py"
/usr/bin/python3 "$ROOT/scripts/check-layers.py"
# The full run (no arguments) runs the suites of SANITIZE_TARGETS under ASan+UBSan after the normal
# suite, and there only: the normal build neither compiles nor registers them (VIM_SKIP_SUITES); with
# ctest arguments, or SANITIZE=0, every suite is built and run normally.
sanitize_targets="${SANITIZE_TARGETS:-test_mesher test_pipeline test_bad_inputs}"
sanitize=0
[ $# -eq 0 ] && [ "${SANITIZE:-1}" != 0 ] && sanitize=1
skip=""
[ $sanitize = 1 ] && skip=$(echo $sanitize_targets | tr ' ' ';')
# Warnings are errors in CI (VIM_WERROR: -Werror on the project's own targets). The full run does not
# build bench/ (no test runs a benchmark; bench/run.sh builds them), BENCH=1 builds them too.
bench=ON
[ $# -eq 0 ] && [ "${BENCH:-0}" != 1 ] && bench=OFF
BUILD_DIR="$BUILD_DIR" CMAKE_ARGS="-DVIM_WERROR=ON -DVIM_BUILD_BENCH=$bench -DVIM_SKIP_SUITES=$skip ${CMAKE_ARGS:-}" \
  bash "$ROOT/scripts/build.sh"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Tests run JOBS at a time on as many cores: OpenBLAS (below CHOLMOD and UMFPACK) threads of its own
# would oversubscribe them and spin (a monolithic-solve test: 2.8x the wall time under load).
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
cd "$BUILD_DIR"
# The full run: the tests JOBS at a time, except those labelled mpi (two ranks each, or a test program
# that starts `mpirun -np 2`), which run after them one at a time.
if [ $# -eq 0 ]; then
  ctest --output-on-failure --timeout 1800 -j"${JOBS:-2}" -LE '^mpi$'
  ctest --output-on-failure --timeout 1800 -L '^mpi$'
else
  ctest --output-on-failure --timeout 1800 "$@"
fi
# The sanitized suites (scripts/sanitize.sh): leak detection on (scripts/lsan.supp), every mesh
# invariant checked, each suite as four GoogleTest shards, two at a time. The mesher suite; the pipeline
# suite, whose tests drive the instrumented vim-pipeline through meshing, simulation, exports, figures
# and studies; the bad-input suite, through every image, scenario and study reader and the fault paths
# (SIGKILL, full disk). fem is linked uninstrumented from this build (FEM_FROM), so its deal.II units
# are not compiled twice; the fem suite and the validation smoke run from scripts/sanitize.sh
# (docs/robustness.md gives the times and results of every suite). Then a 30-second smoke of each
# fuzz target (scripts/fuzz.sh; FUZZ=0 skips it).
if [ $sanitize = 1 ]; then
  TARGETS="$sanitize_targets" FEM_FROM="$BUILD_DIR" JOBS="${JOBS:-2}" \
    bash "$ROOT/scripts/sanitize.sh" "$BUILD_DIR-sanitize"
fi
if [ $# -eq 0 ] && [ "${FUZZ:-1}" != 0 ]; then
  VIM_BUILD_DIR="$BUILD_DIR" JOBS="${JOBS:-2}" bash "$ROOT/scripts/fuzz.sh" 30 "$BUILD_DIR-fuzz"
fi
echo "test.sh: all tests passed in $(( $(date +%s) - start )) s"

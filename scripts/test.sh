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
# Warnings are errors in CI (VIM_WERROR: -Werror on the project's own targets).
BUILD_DIR="$BUILD_DIR" CMAKE_ARGS="-DVIM_WERROR=ON ${CMAKE_ARGS:-}" bash "$ROOT/scripts/build.sh"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cd "$BUILD_DIR"
ctest --output-on-failure --timeout 1800 "$@"
# The full run also builds the mesher and bad-input suites with ASan+UBSan (leak detection on,
# scripts/lsan.supp) and every mesh invariant checked (scripts/sanitize.sh; SANITIZE=0 skips it); the
# bad-input suite drives the instrumented vim-pipeline through the image, scenario and study readers,
# meshing, simulation, figures and the fault paths. SANITIZE_TARGETS chooses the suites (the pipeline
# suite, the fem suite and the validation smoke run from scripts/sanitize.sh: docs/robustness.md gives
# their times and results). fem is linked uninstrumented from this build
# (FEM_FROM), so its deal.II units are not compiled twice. Then a 30-second smoke of each fuzz target
# (scripts/fuzz.sh; FUZZ=0 skips it).
if [ $# -eq 0 ] && [ "${SANITIZE:-1}" != 0 ]; then
  TARGETS="${SANITIZE_TARGETS:-test_mesher test_bad_inputs}" FEM_FROM="$BUILD_DIR" JOBS="${JOBS:-2}" \
    bash "$ROOT/scripts/sanitize.sh" "$BUILD_DIR-sanitize"
fi
if [ $# -eq 0 ] && [ "${FUZZ:-1}" != 0 ]; then
  VIM_BUILD_DIR="$BUILD_DIR" JOBS="${JOBS:-2}" bash "$ROOT/scripts/fuzz.sh" 30 "$BUILD_DIR-fuzz"
fi
echo "test.sh: all tests passed in $(( $(date +%s) - start )) s"

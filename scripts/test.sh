#!/usr/bin/env bash
# README command 2: install dependencies, build, and run every test (CTest; labels unit,
# integration, validation, mpi). Exits non-zero on any failure.
# Pass ctest arguments to select a subset, e.g. `scripts/test.sh -L unit`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-$ROOT/build}"
start=$(date +%s)
bash "$ROOT/scripts/setup-deps.sh"
BUILD_DIR="$BUILD_DIR" bash "$ROOT/scripts/build.sh"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cd "$BUILD_DIR"
ctest --output-on-failure --timeout 1800 "$@"
echo "test.sh: all tests passed in $(( $(date +%s) - start )) s"

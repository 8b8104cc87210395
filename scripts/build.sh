#!/usr/bin/env bash
# Configure and build vim-pipeline (Release, -j2 by default) into ${BUILD_DIR:-build}. UNITY=0 turns
# the unity builds off (VIM_UNITY_BUILD; faster rebuilds after editing one file).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-$ROOT/build}"
JOBS="${JOBS:-2}"
BUILD_TYPE="${BUILD_TYPE:-Release}"
UNITY="$([ "${UNITY:-1}" = 0 ] && echo OFF || echo ON)"
cmake -S "$ROOT" -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE="$BUILD_TYPE" -DVIM_UNITY_BUILD="$UNITY" ${CMAKE_ARGS:-} > "$BUILD_DIR.configure.log" 2>&1 \
  || { cat "$BUILD_DIR.configure.log"; echo "build.sh: cmake configure failed" >&2; exit 1; }
cmake --build "$BUILD_DIR" -j "$JOBS" ${TARGETS:+--target $TARGETS}

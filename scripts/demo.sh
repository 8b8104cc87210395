#!/usr/bin/env bash
# README command 1: install dependencies, build, generate the phantoms, and run the main job —
# VIM meshing of the prostate elastography phantom + a transperineal needle insertion — then print
# where the results are.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-$ROOT/build}"
OUT="${OUT:-$ROOT/out/demo}"
bash "$ROOT/scripts/setup-deps.sh"
BUILD_DIR="$BUILD_DIR" TARGETS="vim-pipeline vim-make-phantom" bash "$ROOT/scripts/build.sh"
BIN="$BUILD_DIR/pipeline/vim-pipeline"
PHANTOM="$BUILD_DIR/examples/vim-make-phantom"
GEN="$ROOT/examples/generated"
mkdir -p "$GEN"
for kind in table1 diamond two-circles; do
  "$PHANTOM" "$kind" "$GEN/$kind.mha"
done
# The prostate phantom with its anatomy labels: the needle's tissues (examples/prostate_needle.yaml).
"$PHANTOM" prostate "$GEN/prostate.mha" --labels "$GEN/prostate_labels.mha"
for kind in table1 prostate; do
  "$BIN" "$GEN/$kind.mha" --info
done
"$BIN" "$GEN/prostate.mha" --labels "$GEN/prostate_labels.mha" --simulate "$ROOT/examples/prostate_needle.yaml" \
  --out "$OUT" --overwrite
echo
echo "demo: results in $OUT"
echo "  mesh:        $OUT/mesh.vtu (open in ParaView / 3D Slicer), exports mesh.vtk/.feb/.msh/.inp"
echo "  simulation:  $OUT/simulation.pvd, $OUT/needle.csv, $OUT/report.json, $OUT/figures/"

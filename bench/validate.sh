#!/usr/bin/env bash
# Full validation sweep of docs/validation.md (CI runs the small subset: ctest -L validation):
#   1. paper Table I at 125, 343, 4096 nodes (bench/table1.cpp, independent TF% metric);
#   2. deformation error vs the fine voxel reference, VIM vs grid at 125, 343, 1000, 4096 nodes,
#      for the 3D sphere (10x stiffer) and the 2D two-inclusion phantom (bench/bench_fem_validate.cpp);
#   3. the prostate phantom (bench/validate_needle.cpp): an x-compression on the 1 mm image (60x50x50) and
#      the needle insertion of examples/prostate_needle.yaml (6 steps) on the 2 mm image (30x25x25), P2 and
#      P1 elements, VIM vs grid vs the voxel reference;
#   4. the plots docs/figures/validation_*.png (bench/validation_plots.cpp reads the tables of 1 and 2;
#      validate_needle writes the prostate plots);
#   5. the prostate needle scenario through the CLI with --mesher vim|grid|voxel (target displacements).
# Usage: bench/validate.sh [build-dir] > docs-tables.md   (PLOTS=dir to write the figures elsewhere)
set -euo pipefail
BUILD=${1:-build}
SRC=$(cd "$(dirname "$0")/.." && pwd)
cmake -S "$SRC" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD" -j"${JOBS:-2}" --target table1 bench_fem_validate validate_needle validation_plots >/dev/null
PLOTS=${PLOTS:-$SRC/docs/figures}
TABLES=$(mktemp -d)
echo "# vim-pipeline validation — commit $(git -C "$SRC" rev-parse --short HEAD 2>/dev/null || echo unknown)," \
     "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores, $(date -u +%F)"
echo
echo '## Table I'
echo '```'
"$BUILD/bench/table1" 125 343 4096 | tee "$TABLES/table1.txt"
echo '```'
"$BUILD/bench/bench_fem_validate" --scenario all 125 343 1000 4096 | tee "$TABLES/deformation.md"
# Prostate (docs/validation.md): compression on the 1 mm image (60x50x50 voxels) with P2 elements (the
# element for nu = 0.45; P1 locks) and, for the record, P1, on VIM meshes without the scenario's needle
# refinement (validate_needle applies it to the needle experiment only); the needle insertion of the scenario (its
# elastic probe support, cutting distance and, for VIM, its mesh.needle_refinement) on the 2 mm image
# (30x25x25), P2 and P1. The compression reference is solved once and cached.
for deg in 2 1; do
  (cd "$SRC" && "$BUILD/bench/validate_needle" --n 60 --skip-needle --degree $deg --ref-cache "$TABLES/ref60.bin" \
     --plots "$PLOTS" 125 343 1000 4096)
done
for deg in 2 1; do
  (cd "$SRC" && "$BUILD/bench/validate_needle" --n 30 --steps 6 --skip-compression --degree $deg --plots "$PLOTS" \
     125 343 1000 4096)
done
"$BUILD/bench/validation_plots" "$PLOTS" "$TABLES/table1.txt" "$TABLES/deformation.md" >&2

SCENARIO="$SRC/examples/prostate_needle.yaml"
prostate() {
  cmake --build "$BUILD" -j"${JOBS:-2}" --target vim-pipeline vim-make-phantom >/dev/null 2>&1 || return 1
  local tmp
  tmp=$(mktemp -d)
  # 2 mm voxels (30x25x25), as the needle rows above, so the voxel reference stays small.
  "$BUILD/examples/vim-make-phantom" prostate "$tmp/prostate.mha" --size 30 --labels "$tmp/labels.mha" >/dev/null || return 1
  echo
  echo '## Prostate needle insertion (CLI, 2 mm image, 1000 nodes; final target displacement norms in mm from report.json)'
  for mesher in vim grid voxel; do
    "$BUILD/pipeline/vim-pipeline" "$tmp/prostate.mha" --labels "$tmp/labels.mha" --mesher "$mesher" --nodes 1000 --quiet \
      --simulate "$SCENARIO" --out "$tmp/$mesher" || return 1
    echo "- $mesher: $(tr -d '\n ' < "$tmp/$mesher/report.json" | grep -o '"final_displacement_[a-z_]*":[-0-9.e+]*' | tr '\n' ' ')"
  done
}
if ! prostate; then
  echo
  echo "Prostate needle scenario skipped: the CLI (vim-make-phantom prostate; vim-pipeline --mesher/--simulate) is not ready."
fi

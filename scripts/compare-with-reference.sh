#!/usr/bin/env bash
# Runs the same vim-pipeline commands with a reference build and with this build and compares every
# output file (scripts/compare-outputs.py): a restructure that must keep the results shows it here.
# Usage: scripts/compare-with-reference.sh REF_BUILD_DIR [NEW_BUILD_DIR] [RTOL]
#   e.g. git worktree add /tmp/ref 2244e10 && BUILD_DIR=/tmp/ref/build bash /tmp/ref/scripts/build.sh
#        scripts/compare-with-reference.sh /tmp/ref/build build 1e-12
# Cases: 3D mesh only with segmentation, 2D mesh, grid and voxel meshers, the prostate needle scenario
# (P1 and P2, direct solver) on VIM, grid and voxel models. Exit 1 on any difference.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
REF="$(cd "$1" && pwd)"
NEW="$(cd "${2:-$ROOT/build}" && pwd)"
RTOL="${3:-1e-12}"
SKIP=("${@:4}")
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
cd "$WORK"
"$NEW/examples/vim-make-phantom" table1 t.mha --size 40 >/dev/null
"$NEW/examples/vim-make-phantom" prostate p.mha --size 40 --labels pl.mha >/dev/null
"$NEW/examples/vim-make-phantom" two-inclusions c.mha --size 60 >/dev/null
sed "s/^solver: .*$/solver: {type: direct}/" "$ROOT/examples/prostate_needle.yaml" > needle.yaml
cases=(
  "t.mha --nodes 300 --threshold 1.5"
  "c.mha --nodes 300"
  "t.mha --nodes 300 --mesher grid"
  "c.mha --mesher voxel"
  "p.mha --labels pl.mha --nodes 400 --simulate needle.yaml --degree 1"
  "p.mha --labels pl.mha --nodes 400 --simulate needle.yaml --degree 2"
  "p.mha --labels pl.mha --nodes 400 --simulate needle.yaml --mesher grid --degree 1"
)
fail=0
for i in "${!cases[@]}"; do
  # shellcheck disable=SC2086
  "$REF/pipeline/vim-pipeline" ${cases[$i]} --out "ref$i" -q
  # shellcheck disable=SC2086
  "$NEW/pipeline/vim-pipeline" ${cases[$i]} --out "new$i" -q
  echo "== vim-pipeline ${cases[$i]}"
  /usr/bin/python3 "$ROOT/scripts/compare-outputs.py" "ref$i" "new$i" --rtol "$RTOL" "${SKIP[@]}" || fail=1
done
exit $fail

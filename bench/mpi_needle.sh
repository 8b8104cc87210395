#!/usr/bin/env bash
# The needle bench of docs/mpi.md: the demo's prostate insertion (P2, examples/prostate_needle.yaml)
# with the TRUS probe clamped instead of elastically supported (volume supports run serially only)
# and 6 steps, meshed with NODES vertices (default 6000), through the CLI on each rank count of RANKS
# (default "1 2"). Prints per run: wall time, peak resident memory and CPU time of every rank; DoFs,
# rank 0's model bytes and cells held from report.json; and the last row's force and lesion
# displacement (equal for every rank count to the solver tolerance).
# Usage: bash bench/mpi_needle.sh [BUILD_DIR]   (NODES=12000 RANKS="2" to change the size and ranks)
set -euo pipefail
BUILD="${1:-build}"
NODES="${NODES:-6000}"
RANKS="${RANKS:-1 2}"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" > /dev/null
/usr/bin/python3 - "$ROOT/examples/prostate_needle.yaml" "$WORK/needle.yaml" <<'PY'
import re, sys
s = open(sys.argv[1]).read()
s, n = re.subn(r",\n\s*support: \{elastic: \{stiffness: [0-9.]+\}\}\}", "}", s)
s, m = re.subn(r"\n  steps: [0-9]+", "\n  steps: 6", s)
assert n == 1 and m == 1, "examples/prostate_needle.yaml changed: update bench/mpi_needle.sh"
open(sys.argv[2], "w").write(s)
PY
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
for r in $RANKS; do
  start=$(date +%s.%N)
  mpirun -np "$r" --oversubscribe /usr/bin/time -f "  rank peak %M kB, CPU %U s user + %S s system" \
    "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --simulate "$WORK/needle.yaml" --nodes "$NODES" \
    --export none --out "$WORK/out$r" -q 2> "$WORK/time$r"
  end=$(date +%s.%N)
  echo "nodes=$NODES ranks=$r wall $(echo "$end - $start" | bc) s"
  grep "rank peak" "$WORK/time$r"
  /usr/bin/python3 - "$WORK/out$r/report.json" "$WORK/out$r/needle.csv" <<'PY'
import csv, json, sys
r = json.load(open(sys.argv[1]))
last = list(csv.DictReader(open(sys.argv[2])))[-1]
m = r["simulation"]["model"]
print("  %d vertices, %d DoFs; rank 0's model %.1f MB, %d cells held; final axial force %s mN, lesion %s mm" % (
    m["vertices"], m["dofs"], m["memory_bytes"] / 1e6, m["cells_held"], last["axial_force"], last["lesion_norm"]))
PY
done

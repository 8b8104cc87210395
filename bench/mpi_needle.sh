#!/usr/bin/env bash
# The needle bench of docs/mpi.md: the demo's prostate insertion (P2, examples/prostate_needle.yaml)
# with the TRUS probe clamped instead of elastically supported (volume supports run serially only)
# and 6 steps, meshed with NODES vertices (default 6000), through the CLI for each run of RUNS, each
# RANKS:SOLVER (default "1:auto 2:direct 2:amg": serial, where auto is CHOLMOD; 2 ranks with MUMPS;
# 2 ranks with CG + AMG). Prints per run: wall time and its ratio to the first run's, peak resident
# memory and CPU time of every rank; DoFs, the solver and why, rank 0's model bytes and cells held from
# report.json; and the last row's force and lesion displacement (equal for every run to the solver
# tolerance).
# Usage: bash bench/mpi_needle.sh [BUILD_DIR]   (NODES=12000 RUNS="2:direct" to change the size and runs)
set -euo pipefail
BUILD="${1:-build}"
NODES="${NODES:-6000}"
RUNS="${RUNS:-1:auto 2:direct 2:amg}"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" --labels "$WORK/labels.mha" > /dev/null
/usr/bin/python3 - "$ROOT/examples/prostate_needle.yaml" "$WORK/needle.yaml" <<'PY'
import re, sys
s = open(sys.argv[1]).read()
s, n = re.subn(r",\n\s*support: \{elastic: \{stiffness: [0-9.]+\}\}\}", "}", s)
s, m = re.subn(r"\n  steps: [0-9]+", "\n  steps: 6", s)
assert n == 1 and m == 1, "examples/prostate_needle.yaml changed: update bench/mpi_needle.sh"
open(sys.argv[2], "w").write(s)
PY
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
first=""
for run in $RUNS; do
  r="${run%%:*}" solver="${run#*:}"
  sed "s/solver: {type: auto,/solver: {type: $solver,/" "$WORK/needle.yaml" > "$WORK/needle_$solver.yaml"
  grep -q "solver: {type: $solver," "$WORK/needle_$solver.yaml"
  start=$(date +%s.%N)
  mpirun -np "$r" --oversubscribe /usr/bin/time -f "  rank peak %M kB, CPU %U s user + %S s system" \
    "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --labels "$WORK/labels.mha" --simulate "$WORK/needle_$solver.yaml" --nodes "$NODES" \
    --export none --out "$WORK/out$run" -q 2> "$WORK/time$run"
  end=$(date +%s.%N)
  wall=$(echo "$end - $start" | bc)
  first="${first:-$wall}"
  echo "nodes=$NODES ranks=$r solver=$solver wall $wall s, $(echo "scale=2; $wall / $first" | bc) x the first run"
  grep "rank peak" "$WORK/time$run"
  /usr/bin/python3 - "$WORK/out$run/report.json" "$WORK/out$run/needle.csv" <<'PY'
import csv, json, sys
r = json.load(open(sys.argv[1]))
last = list(csv.DictReader(open(sys.argv[2])))[-1]
m = r["simulation"]["model"]
s = r["simulation"]["needles"][0]["solver"]
print("  %d vertices, %d DoFs; %s (%s); rank 0's model %.1f MB, %d cells held; final axial force %s mN, lesion %s mm" % (
    m["vertices"], m["dofs"], s["method"], s.get("reason", "serial"), m["memory_bytes"] / 1e6, m["cells_held"],
    last["axial_force"], last["lesion_norm"]))
PY
done

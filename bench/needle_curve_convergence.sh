#!/usr/bin/env bash
# Curve convergence of the prostate demo (docs/needle-model.md, the tip bearing: curve convergence):
# examples/prostate_needle.yaml (P2; the direct solver, so that the finest mesh stays on the Cholesky
# path; the phantom's anatomy labels for its needle tissues, as scripts/demo.sh) on VIM meshes of NODES
# (default "1500 4500 13500": the node count triples), and on the middle
# mesh with twice the steps (72). For the axial force, its friction and tip parts, and every target's
# displacement vector, prints max over the steps of |X_a − X_b| / max over the steps of |X_b| (b the
# finer run; the 72-step run read at the 36 steps' depths) for each pair of successive meshes and for
# 36 → 72 steps. Exits 1 if an entry of the two finest meshes or of the step pair exceeds LIMIT
# (default 0.03).
# Usage: bash bench/needle_curve_convergence.sh [BUILD_DIR]   (tens of minutes on 2 shared cores)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
NODES="${NODES:-1500 4500 13500}"
LIMIT="${LIMIT:-0.03}"
WORK="${WORK:-$(mktemp -d)}"
mkdir -p "$WORK"
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" --labels "$WORK/labels.mha" > /dev/null
sed -e 's/^solver: .*/solver: {type: direct, tolerance: 1.0e-10}/' -e 's/^output: .*/output: {every: 0}/' \
  "$ROOT/examples/prostate_needle.yaml" > "$WORK/direct.yaml"
grep -q '^solver: {type: direct' "$WORK/direct.yaml" || { echo "needle_curve_convergence.sh: no solver line" >&2; exit 2; }
sed 's/^  steps: 36.*/  steps: 72/' "$WORK/direct.yaml" > "$WORK/direct72.yaml"
grep -q '^  steps: 72' "$WORK/direct72.yaml" || { echo "needle_curve_convergence.sh: no steps line" >&2; exit 2; }
run() {  # run NAME NODES SCENARIO
  [ -s "$WORK/$1/needle.csv" ] && return 0
  "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --labels "$WORK/labels.mha" --simulate "$3" \
    --nodes "$2" --out "$WORK/$1" --export none -q
}
set -- $NODES
for n in "$@"; do run "n$n" "$n" "$WORK/direct.yaml"; done
run "n${2}_72" "$2" "$WORK/direct72.yaml"
/usr/bin/python3 - "$LIMIT" "$WORK" "$@" <<'PY'
import csv, json, math, sys
limit, work, nodes = float(sys.argv[1]), sys.argv[2], sys.argv[3:]

def load(name):
    rows = list(csv.DictReader(open("%s/%s/needle.csv" % (work, name))))
    report = json.load(open("%s/%s/report.json" % (work, name)))
    return rows, report

def series(rows):
    targets = sorted({k[:-3] for k in rows[0] if k.endswith("_dx")})
    out = {k: [[float(r[k])] for r in rows] for k in ("axial_force", "friction_force", "tip_force")}
    for t in targets:
        out[t] = [[float(r[t + "_d" + c]) for c in "xyz"] for r in rows]
    return out

def compare(a, b):
    res = {}
    for key in b:
        diff = max(math.dist(x, y) for x, y in zip(a[key], b[key]))
        scale = max(math.hypot(*y) for y in b[key])
        res[key] = diff / scale if scale > 0 else 0.0
    return res

runs = {}
for n in nodes:
    rows, rep = load("n" + n)
    runs[n] = series(rows)
    nd = rep["simulation"]["needles"][0]
    print("--nodes %s: %d vertices, %d stations, R %.2f mm, final axial force %.2f" %
          (n, rep["mesh"]["nodes"], nd["shaft_points"], nd["coupling_radius"], float(rows[-1]["axial_force"])))
rows72, _ = load("n%s_72" % nodes[1])
fine72 = {k: v[::2] for k, v in series(rows72).items()}
pairs = [("%s -> %s nodes" % (a, b), compare(runs[a], runs[b]), b == nodes[-1]) for a, b in zip(nodes, nodes[1:])]
pairs.append(("36 -> 72 steps, %s nodes" % nodes[1], compare(runs[nodes[1]], fine72), True))
keys = list(pairs[0][1])
print("| comparison | " + " | ".join(keys) + " |")
print("|---|" + "---|" * len(keys))
failed = False
for name, res, checked in pairs:
    print("| %s | " % name + " | ".join("%.2f%%" % (100 * res[k]) for k in keys) + " |")
    failed = failed or (checked and any(v > limit for v in res.values()))
sys.exit(1 if failed else 0)
PY

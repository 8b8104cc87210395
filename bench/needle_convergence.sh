#!/usr/bin/env bash
# The needle convergence study of docs/needle-model.md §8: the prostate demo scenario
# (examples/prostate_needle.yaml, with the direct solver so the finest mesh stays on the Cholesky path)
# on VIM meshes of NODES (default "1500 4500 13500": the node count triples). Prints per mesh the
# vertices, shaft stations, coupling radius, final axial force and target displacements, then the
# relative change of each between successive meshes and the observed order in h,
# p = ln(d1/d2) / ln(r^(1/3)) with r the node ratio. Exits 1 if the force or a target changes by more
# than LIMIT (default 0.02) between the two finest meshes.
# Usage: bash bench/needle_convergence.sh [BUILD_DIR]   (about 3 min on 2 idle cores)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
NODES="${NODES:-1500 4500 13500}"
LIMIT="${LIMIT:-0.02}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" --labels "$WORK/labels.mha" > /dev/null
sed 's/^solver: .*/solver: {type: direct, tolerance: 1.0e-10}/' "$ROOT/examples/prostate_needle.yaml" \
  > "$WORK/direct.yaml"
grep -q '^solver: {type: direct' "$WORK/direct.yaml" || { echo "needle_convergence.sh: no solver line" >&2; exit 2; }
for n in $NODES; do
  "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --labels "$WORK/labels.mha" --simulate "$WORK/direct.yaml" --nodes "$n" \
    --out "$WORK/n$n" --export none -q
done
/usr/bin/python3 - "$LIMIT" $(for n in $NODES; do echo "$WORK/n$n"; done) <<'PY'
import json, math, sys
limit, runs = float(sys.argv[1]), sys.argv[2:]
rows = []
for d in runs:
    r = json.load(open(d + "/report.json"))
    n = r["simulation"]["needles"][0]
    f = n["final"]
    q = {"axial force": f["axial_force"]}
    q.update({k: v["norm"] for k, v in sorted(f["targets"].items())})
    rows.append((r["mesh"]["nodes"], n["shaft_points"], n["coupling_radius"], q))
    print("%6d vertices  %2d stations  R %.2f mm  " % rows[-1][:3] +
          "  ".join("%s %.4f" % kv for kv in q.items()))
failed = False
for key in rows[0][3]:
    x = [row[3][key] for row in rows]
    d = [(b - a) / a if a else 0.0 for a, b in zip(x, x[1:])]
    ratio = rows[-1][0] / rows[-2][0]
    order = ""
    if len(d) >= 2 and d[-1] * d[-2] > 0 and abs(d[-1]) < abs(d[-2]):
        order = "  order %.1f" % (math.log(d[-2] / d[-1]) / math.log(ratio ** (1.0 / 3.0)))
    print("%-12s changes %s%s" % (key, " ".join("%+.2f%%" % (100 * c) for c in d), order))
    failed = failed or abs(d[-1]) > limit
sys.exit(1 if failed else 0)
PY

#!/usr/bin/env bash
# The demo insertion (examples/prostate_needle.yaml on `vim-make-phantom prostate`) on the linear and on
# the neo-Hookean model, timed in the same run: the needle's run time (report.json needle
# timing.run_seconds: the stepping and its solves; meshing and files excluded) per model, their ratio
# (goal: neo-Hookean at most 10x the linear), the Newton iterations, and the linear model's error from
# a --compare-linear run (per target and the axial force, at the last step and the largest over the
# steps). NODES (default the demo's 3000) sets --nodes; OPENBLAS_NUM_THREADS=1 is set (CHOLMOD's BLAS
# threads only spin on a shared 2-core machine).
# Usage: bash bench/finite_strain_needle.sh [BUILD_DIR]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
NODES="${NODES:-3000}"
export OPENBLAS_NUM_THREADS=1
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" --labels "$WORK/labels.mha" > /dev/null
sed 's/^  poisson_ratio: 0.45/  poisson_ratio: 0.45\n  model: neo-hookean/' "$ROOT/examples/prostate_needle.yaml" > "$WORK/neo-hookean.yaml"
cp "$ROOT/examples/prostate_needle.yaml" "$WORK/linear.yaml"
for model in linear neo-hookean; do
  "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --labels "$WORK/labels.mha" --nodes "$NODES" --simulate "$WORK/$model.yaml" \
    --export none -q --out "$WORK/$model"
done
"$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --labels "$WORK/labels.mha" --nodes "$NODES" --simulate "$WORK/neo-hookean.yaml" \
  --export none -q --compare-linear --out "$WORK/compare"
/usr/bin/python3 - "$WORK" <<'PY'
import json, sys
work = sys.argv[1]
t = {}
for model in ("linear", "neo-hookean"):
    s = json.load(open("%s/%s/report.json" % (work, model)))["simulation"]
    n = s["needles"][0]
    t[model] = n["timing"]["run_seconds"]
    extra = ""
    if model == "neo-hookean":
        steps = n["newton"]["per_step"]
        extra = "%d solves, %d Newton iterations, %d halvings" % (
            sum(x["solves"] for x in steps), sum(x["iterations"] for x in steps), sum(x["halvings"] for x in steps))
    print("| %-11s | %6d | %8.2f | %9.2f | %s |" % (model, n["solver"]["n_dofs"], t[model],
                                                    s["final_axial_force"], extra))
print("neo-Hookean / linear needle run time: %.1f" % (t["neo-hookean"] / t["linear"]))
c = json.load(open("%s/compare/report.json" % work))["simulation"]["compare_linear"]
def row(name, e):
    last = e["relative_difference"]
    big = e["largest_relative_difference"]
    fmt = lambda v: "-" if v is None else "%.2f %%" % (100 * v)
    print("| %s | %s | %s (step %s) |" % (name, fmt(last), fmt(big), e["largest_step"]))
row("axial force", c["axial_force"])
for name, e in c["targets"].items():
    row("target " + name, e)
PY

#!/usr/bin/env bash
# The neo-Hookean static compression's time as a ratio to the linear one, measured in the same run: the
# prostate phantom (vim-make-phantom prostate), P2, NODES (default 1500) nodes, compressed along x by
# 10 % (x_max held, x_min moved 6 mm; docs/finite-strain.md), solved REPEAT (default 3) times per model,
# alternating; prints per model the median solve time (report.json simulation.static_load.timing.
# solve_seconds, the solve alone: mesh and files excluded) and the ratio neo-Hookean / linear.
# Usage: bash bench/finite_strain.sh [BUILD_DIR]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
NODES="${NODES:-1500}"
REPEAT="${REPEAT:-3}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" > /dev/null
for model in linear neo-hookean; do
  cat > "$WORK/$model.yaml" <<YAML
material: {model: $model, youngs_modulus: image, scale: 1.0, clamp: [1.0, 1000.0], poisson_ratio: 0.45}
mesh: {degree: 2}
boundary_conditions:
  - {type: fixed, region: {box_face: x_max}}
  - {type: displacement, region: {box_face: x_min}, value: [6, 0, 0]}
targets: [{name: centre, position: [0, 0, 0]}, {name: lateral, position: [-15, 5, 3]}]
YAML
done
for k in $(seq "$REPEAT"); do
  for model in linear neo-hookean; do
    "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --nodes "$NODES" --simulate "$WORK/$model.yaml" \
      --export none -q --out "$WORK/${model}_$k"
  done
done
/usr/bin/python3 - "$WORK" "$REPEAT" <<'PY'
import json, statistics, sys
work, repeat = sys.argv[1], int(sys.argv[2])
median = {}
for model in ("linear", "neo-hookean"):
    runs = [json.load(open("%s/%s_%d/report.json" % (work, model, k)))["simulation"]["static_load"]
            for k in range(1, repeat + 1)]
    median[model] = statistics.median(r["timing"]["solve_seconds"] for r in runs)
    extra = ""
    if model == "neo-hookean":
        n = runs[0]["newton"]
        extra = "%d Newton iterations in %d load steps" % (n["iterations"], len(n["load_steps"]))
    print("| %-11s | %6d | %8.2f | %s |" % (model, runs[0]["solver"]["n_dofs"], median[model], extra))
print("neo-Hookean / linear solve time: %.2f" % (median["neo-hookean"] / median["linear"]))
PY

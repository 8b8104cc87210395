#!/usr/bin/env bash
# The linear model's error on the prostate phantom (vim-make-phantom prostate), P2, NODES (default 1500)
# nodes, compressed along x by PERCENT (default "5 10 20") % of its 60 mm (x_max held, x_min moved;
# docs/finite-strain.md): one --compare-linear run per compression; prints per compression the relative
# difference |linear − neo-Hookean| / |neo-Hookean| of each target's displacement, of the moved face's
# reaction and of the largest displacement (report.json simulation.compare_linear). Then the TRUS
# probe pressed PROBE_MM (default 5; empty: not run) mm towards the gland: the phantom's probe
# cylinder (radius 6 mm along x through y = -22, z = 0) moved along +y, the anterior face y_max held.
# Usage: bash bench/compare_linear.sh [BUILD_DIR]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
NODES="${NODES:-1500}"
PERCENT="${PERCENT-5 10 20}"
PROBE_MM="${PROBE_MM-5}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" prostate "$WORK/prostate.mha" > /dev/null
for p in $PERCENT; do
  shift_mm=$(/usr/bin/python3 -c "print(0.6 * $p)")
  cat > "$WORK/c$p.yaml" <<YAML
material: {model: neo-hookean, youngs_modulus: image, scale: 1.0, clamp: [1.0, 1000.0], poisson_ratio: 0.45}
mesh: {degree: 2}
boundary_conditions:
  - {type: fixed, region: {box_face: x_max}}
  - {type: displacement, region: {box_face: x_min}, value: [$shift_mm, 0, 0]}
targets: [{name: centre, position: [0, 0, 0]}, {name: lateral, position: [-15, 5, 3]}]
YAML
  "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --nodes "$NODES" --simulate "$WORK/c$p.yaml" \
    --compare-linear --export none -q --out "$WORK/c$p"
done
if [ -n "$PROBE_MM" ]; then
  cat > "$WORK/probe.yaml" <<YAML
material: {model: neo-hookean, youngs_modulus: image, scale: 1.0, clamp: [1.0, 1000.0], poisson_ratio: 0.45}
mesh: {degree: 2}
boundary_conditions:
  - {type: fixed, region: {box_face: y_max}}
  - {type: displacement, region: {cylinder: {center: [0, -22, 0], axis: [1, 0, 0], radius: 6}}, value: [0, $PROBE_MM, 0]}
targets: [{name: centre, position: [0, 0, 0]}, {name: lateral, position: [-15, 5, 3]}]
YAML
  "$BUILD/pipeline/vim-pipeline" "$WORK/prostate.mha" --nodes "$NODES" --simulate "$WORK/probe.yaml" \
    --compare-linear --export none -q --out "$WORK/probe"
fi
/usr/bin/python3 - "$WORK" "$PROBE_MM" $PERCENT <<'PY'
import json, sys
work, probe_mm, percents = sys.argv[1], sys.argv[2], sys.argv[3:]
print("| compression | target centre | target lateral | reaction x_min (linear / neo-Hookean, x) | max displacement |")
print("|---|---|---|---|---|")
for p in percents:
    c = json.load(open("%s/c%s/report.json" % (work, p)))["simulation"]["compare_linear"]
    t = c["targets"]
    r = next(e for e in c["reactions"] if e["region"].endswith("x_min"))
    print("| %s %% | %.2f %% | %.2f %% | %.2f %% (%.4g / %.4g) | %.2f %% |" % (
        p, 100 * t["centre"]["relative_difference"], 100 * t["lateral"]["relative_difference"],
        100 * r["relative_difference"], r["linear"][0], r["neo-hookean"][0],
        100 * c["max_displacement"]["relative_difference"]))
if probe_mm:
    c = json.load(open("%s/probe/report.json" % work))["simulation"]["compare_linear"]
    t = c["targets"]
    r = next(e for e in c["reactions"] if "cylinder" in e["region"])
    print()
    print("| probe press | target centre | target lateral | probe reaction (linear / neo-Hookean, y) | max displacement |")
    print("|---|---|---|---|---|")
    print("| %s mm | %.2f %% | %.2f %% | %.2f %% (%.4g / %.4g) | %.2f %% |" % (
        probe_mm, 100 * t["centre"]["relative_difference"], 100 * t["lateral"]["relative_difference"],
        100 * r["relative_difference"], r["linear"][1], r["neo-hookean"][1],
        100 * c["max_displacement"]["relative_difference"]))
PY

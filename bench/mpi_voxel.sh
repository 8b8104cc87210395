#!/usr/bin/env bash
# The voxel compression bench of docs/mpi.md: a table1 phantom of N³ voxels (default 128) compressed
# by 5 % along z through the CLI (--mesher voxel, solver.type multigrid: p4est with the matrix-free
# multigrid), on each rank count of RANKS (default "1 2"). Prints per run: wall time, peak resident
# memory of every rank, DoFs, CG iterations and the solve's parts from report.json.
# Usage: bash bench/mpi_voxel.sh [BUILD_DIR]   (N=64 RANKS="1 2" to change the size and ranks)
set -euo pipefail
BUILD="${1:-build}"
N="${N:-128}"
RANKS="${RANKS:-1 2}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
"$BUILD/examples/vim-make-phantom" table1 "$WORK/image.mha" --size "$N" > /dev/null
cat > "$WORK/squeeze.yaml" <<YAML
material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.45}
boundary_conditions:
  - {type: fixed, region: {box_face: z_min}}
  - {type: displacement, region: {box_face: z_max}, value: [0, 0, -0.15]}
output: {fields: [displacement, von_mises]}
solver: {type: multigrid, tolerance: 1e-8}
YAML
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
for r in $RANKS; do
  start=$(date +%s.%N)
  mpirun -np "$r" --oversubscribe /usr/bin/time -f "  rank peak %M kB, CPU %U s user + %S s system" "$BUILD/pipeline/vim-pipeline" \
    "$WORK/image.mha" --mesher voxel --simulate "$WORK/squeeze.yaml" --out "$WORK/out$r" -q 2> "$WORK/time$r"
  end=$(date +%s.%N)
  echo "N=$N ranks=$r wall $(echo "$end - $start" | bc) s"
  grep "rank peak" "$WORK/time$r"
  /usr/bin/python3 - "$WORK/out$r/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
s = r["simulation"]["static_load"]
print("  method %s, %d DoFs, %d CG iterations (relative residual %.1e)" % (
    s["solver"]["method"], s["solver"]["n_dofs"], s["solver"]["iterations"], s["solver"]["residual"]))
print("  solve %.1f s = set-up and assembly %.1f s + multigrid set-up %.1f s + CG %.1f s; run total %.1f s" % (
    s["timing"]["solve_seconds"], s["timing"]["assemble_seconds"], s["timing"]["precondition_seconds"],
    s["timing"]["cg_seconds"], r["timing"]["total"]))
PY
done

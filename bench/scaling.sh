#!/usr/bin/env bash
# Scaling study (docs/performance.md): VIM on the Table I sphere phantom at n³ voxels (n = 64, 128, 256) from
# the regular grid nearest each node budget (~1k, ~10k, ~50k). One bench_mesher_scaling process per
# pair, so VmHWM (/proc/self/status) is that pair's peak memory. Prints a markdown table, least-squares
# growth exponents of s/iteration vs voxels (per budget) and vs elements (per image), and writes
# log-log PNG plots with bench/scaling_plots when that target can be built (it links vim_pipeline).
#
# Usage: bench/scaling.sh [build-dir] [out-dir]     (defaults: ./build, ./scaling-out)
# Environment:
#   IMAGES="64 128 256"  BUDGETS="1000 10000 50000"
#   MAXIT=3          iterations per run (time per iteration = mean of the first min(3, MAXIT));
#                    MAXIT=50 runs to convergence (Eq. 9) like the optimiser's default
#   CONVERGE="256:50000"  pairs n:budget always run to convergence (MAXIT 50), e.g. the issue's target row
#   THREADS=0        TBB threads (0 = default);  NICE=10  niceness of the runs
#   REUSE=1          keep pairs whose OUT/run_N_B.log already holds a ROW line (load from run_N_B.log.load)
#   NO_BUILD=1       do not (re)build bench_mesher_scaling when it exists;  PLOTS=0  no PNGs
# Pairs whose regular-grid edge would be < 2 voxels (e.g. 64³ with 50k nodes: 1.8 voxels, about one
# voxel per element) are skipped with a message: the prefix-sum enclosure has nothing to sum there.
set -euo pipefail
BUILD=${1:-build}
OUT=${2:-scaling-out}
SRC=$(cd "$(dirname "$0")/.." && pwd)
IMAGES=${IMAGES:-"64 128 256"}
BUDGETS=${BUDGETS:-"1000 10000 50000"}
MAXIT=${MAXIT:-3}
CONVERGE=${CONVERGE:-"256:50000"}
THREADS=${THREADS:-0}
NICE=${NICE:-10}
mkdir -p "$OUT"
if [ ! -x "$BUILD/bench/bench_mesher_scaling" ] || [ -z "${NO_BUILD:-}" ]; then
  cmake -S "$SRC" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"${JOBS:-1}" --target bench_mesher_scaling >/dev/null
fi
ROWS="$OUT/rows.txt"
: > "$ROWS"
echo "# VIM scaling — commit $(git -C "$SRC" rev-parse --short HEAD 2>/dev/null || echo unknown)," \
     "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores, $(date -u '+%F %H:%M') UTC"
for n in $IMAGES; do
  for b in $BUDGETS; do
    # nodes per axis as nodes_per_axis_for_budget on a cube: largest k with k³ <= budget
    k=$(awk -v b="$b" 'BEGIN { k = int(b ^ (1 / 3) + 1e-9); while ((k + 1) ^ 3 <= b) k++; while (k ^ 3 > b) k--; print k }')
    edge=$(awk -v n="$n" -v k="$k" 'BEGIN { printf "%.2f", n / (k - 1) }')
    if awk -v e="$edge" 'BEGIN { exit !(e < 2) }'; then
      echo "skip ${n}^3 x ${b} nodes: grid edge ${edge} voxels (< 2; about $(awk -v n="$n" -v k="$k" 'BEGIN { printf "%.1f", n^3 / (6 * (k-1)^3) }') voxels per element)" >&2
      continue
    fi
    it=$MAXIT
    case " $CONVERGE " in *" $n:$b "*) it=50 ;; esac
    log="$OUT/run_${n}_${b}.log"
    if [ -n "${REUSE:-}" ] && grep -q '^ROW' "$log" 2>/dev/null; then  # keep an earlier run of this pair
      echo "$(grep '^ROW' "$log") $(cat "$log.load" 2>/dev/null || echo "- -")" >> "$ROWS"
      echo "reused ${n}^3 x ${b}: $(grep '^total' "$log")" >&2
      continue
    fi
    load=$(cut -d' ' -f1 /proc/loadavg)
    nice -n "$NICE" "$BUILD/bench/bench_mesher_scaling" --n "$n" --nodes "$b" --max-iterations "$it" \
      --threads "$THREADS" > "$log"
    load2=$(cut -d' ' -f1 /proc/loadavg)
    echo "$load $load2" > "$log.load"
    echo "$(grep '^ROW' "$log") $load $load2" >> "$ROWS"
    echo "done ${n}^3 x ${b}: $(grep '^total' "$log")" >&2
  done
done

echo
echo "| image | voxels | nodes | elements | set-up s | s/iteration (mean of first 3) | CPU/wall | ≈ CPU s/iteration | iterations | converged | VmHWM MB | load (start/end) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
awk '{ printf "| %d³ | %.3g | %d | %d | %.2f | %.2f | %.2f | %.2f | %d | %s | %.0f | %s / %s |\n",
         $2, $3, $4, $5, $6, $7, $11, $7 * $11, $8, ($9 ? "yes" : "no"), $10, $12, $13 }' "$ROWS"
echo
# Least-squares slope of log(s/iteration) against log(x) within each group with >= 2 points; the
# second exponent uses CPU s/iteration (wall × CPU/wall of the run), less sensitive to machine load.
fit() {  # $1 = group column, $2 = x column, $3 = label
  awk -v g="$1" -v xc="$2" -v label="$3" '
    function slope(k) { d = n[k] * sxx[k] - sx[k] * sx[k]; return d > 0 ? (n[k] * sxy[k] - sx[k] * sy[k]) / d : 0 }
    function slopec(k) { d = n[k] * sxx[k] - sx[k] * sx[k]; return d > 0 ? (n[k] * sxyc[k] - sx[k] * syc[k]) / d : 0 }
    { k = $g; x = log($xc); y = log($7); yc = log($7 * $11); n[k]++; sx[k] += x; sy[k] += y; syc[k] += yc
      sxx[k] += x * x; sxy[k] += x * y; sxyc[k] += x * yc }
    END { for (k in n) if (n[k] >= 2)
            printf "s/iteration ~ %s^%.2f, CPU s/iteration ~ %s^%.2f  (%s, %d points)\n", label, slope(k), label, slopec(k), k, n[k] }' "$ROWS"
}
echo "Growth exponents (least squares on log-log):"
fit 4 3 "voxels" | sed 's/(\([0-9]*\),/(\1 nodes,/' | sort
fit 2 5 "elements" | sed 's/(\([0-9]*\),/(n = \1,/' | sort
awk '{ $1 = "all" } 1' "$ROWS" > "$ROWS.all"
ROWS="$ROWS.all" fit 1 5 "elements" | sed 's/(all,/(all runs,/'
rm -f "$ROWS.all"

# Plots: scaling_plots links vim_pipeline (write_line_plot of pipeline/figures.hpp); PLOTS=0 skips
# them (building vim_pipeline also builds vim_fem, deal.II: minutes on a fresh build dir).
if [ "${PLOTS:-1}" = 0 ]; then
  echo "plots skipped (PLOTS=0)"
elif cmake --build "$BUILD" -j"${JOBS:-1}" --target scaling_plots >/dev/null 2>&1 && [ -x "$BUILD/bench/scaling_plots" ]; then
  "$BUILD/bench/scaling_plots" "$OUT" "$ROWS"
else
  echo "plots skipped: could not build scaling_plots (needs vim_pipeline)"
fi

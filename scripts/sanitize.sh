#!/usr/bin/env bash
# Builds the mesher and pipeline test suites with -fsanitize=address,undefined (VIM_SANITIZE=ON)
# and the mesh-invariant checks on (VIM_CHECKED=ON: every VIM stage of every test run is checked)
# in a separate build dir and runs them. CI (scripts/test.sh) runs the mesher suite this way
# (TARGETS=test_mesher); the pipeline suite needs a full ASan build of the deal.II code (~1 h on
# the 2-core machine) and runs from this script.
#   scripts/sanitize.sh [BUILD_DIR]            (default: ../build-sanitize next to the checkout)
# Environment: JOBS (default 1), TARGETS (default "test_mesher test_pipeline"), CONFIGURE_ONLY=1 to
# stop after cmake, GTEST_FILTER passed through.
# Leak detection is off: MPI and deal.II leave intentional allocations at exit.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/../build-sanitize}
jobs=${JOBS:-1}
targets=${TARGETS:-"test_mesher test_pipeline"}

# Release, not RelWithDebInfo: deal_ii_setup_target only knows Debug/Release. -g for stacks.
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DVIM_SANITIZE=ON -DVIM_CHECKED=ON -DVIM_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="-g" >/dev/null
echo "configured $build (VIM_SANITIZE=ON, VIM_CHECKED=ON)"
[ "${CONFIGURE_ONLY:-0}" = 1 ] && exit 0
cmake --build "$build" -j"$jobs" --target $targets

export ASAN_OPTIONS=detect_leaks=0:abort_on_error=0:halt_on_error=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
status=0
summary=""
for t in $targets; do
  exe=$(find "$build/tests" -maxdepth 2 -type f -name "$t" -perm -u+x | head -1)
  log="$build/$t.sanitize.log"
  echo "== $t (log: $log)"
  set +e
  (cd "$build/tests" && "$exe") >"$log" 2>&1
  rc=$?
  set -e
  reports=$(grep -cE 'ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer' "$log" || true)
  passed=$(grep -oE '\[  PASSED  \] [0-9]+' "$log" | grep -oE '[0-9]+$' || echo 0)
  failed=$(grep -oE '\[  FAILED  \] [0-9]+ test' "$log" | grep -oE '[0-9]+' || echo 0)
  [ "$rc" -ne 0 ] || [ "$reports" -ne 0 ] && status=1
  summary+=$(printf '%-14s exit %-3s passed %-4s failed %-4s sanitizer reports %s' "$t" "$rc" "$passed" "$failed" "$reports")$'\n'
done
echo "== summary"
printf '%s' "$summary"
[ $status -eq 0 ] && echo "sanitizer run clean" || echo "sanitizer run NOT clean (see logs)"
exit $status

#!/usr/bin/env bash
# Builds the test suites with -fsanitize=address,undefined (VIM_SANITIZE=ON: the project's own
# code; deal.II, ITK and VTK are the uninstrumented system libraries) in a separate build dir and runs
# them, timing the build and the run of each suite. The suites of CHECKED_TARGETS (default: all) are
# built with the mesh-invariant checks on (VIM_CHECKED=ON: every VIM stage of every test run is
# checked) in BUILD_DIR; any others in BUILD_DIR-unchecked without them (the instrumented mesher is
# then compiled twice). The instrumented code is compiled at -O0 with line tables (-g1), enough for
# the sanitizers' stacks, except the mesher and the needle library, where the suites spend their
# instrumented time, at -O1 (vim_sanitize_optimized in CMakeLists.txt). Each suite runs as 2 x JOBS
# GoogleTest shards (GTEST_TOTAL_SHARDS), JOBS processes at a time: an instrumented process linking
# deal.II takes 1-3 s of CPU to start (its dynamic loading under ASan), so one process per test would
# spend minutes on starts; PER_TEST=1 runs every test in its own process through CTest instead (a
# crash or sanitizer report then names its test alone). CI (scripts/test.sh) runs the mesher, pipeline
# and bad-input suites this way (SANITIZE_TARGETS chooses); the fem suite and the validation smoke
# run from this script (docs/robustness.md records the last run and its commit).
#   scripts/sanitize.sh [BUILD_DIR]            (default: ../build-sanitize next to the checkout)
# Environment: JOBS (default 1: build and test parallelism), TARGETS (default: every suite below),
# CHECKED_TARGETS (default: every suite of TARGETS),
# CONFIGURE_ONLY=1 to stop after cmake, GTEST_FILTER (a GoogleTest filter for every suite, turned into
# ctest -R/-E), FILTER_<suite> (e.g. FILTER_test_pipeline: a filter for that suite alone),
# VALIDATION_FILTER (the validation smoke; default below), FAST_UNWIND (default 1: ASan's fast
# unwinder for the stacks of allocations; 0: full stacks, several times slower per allocation),
# UNITY (default 1: unity builds, VIM_UNITY_BUILD; 0: one unit per file), CMAKE_ARGS added to the
# configure line (e.g. -DCMAKE_CXX_COMPILER_LAUNCHER=ccache), FEM_FROM (a
# normal build dir of the same checkout: its vim_fem is brought up to date and linked uninstrumented
# instead of compiling fem's deal.II units again; not with test_fem, which would then check nothing).
# Leak detection is on; scripts/lsan.supp suppresses only the intentional allocations of MPI,
# deal.II and the libraries below them. Sanitizer reports go to BUILD_DIR/reports/SUITE.PID (one
# file per process, so a report of a vim-pipeline run started by a test is counted too).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/../build-sanitize}
jobs=${JOBS:-1}
targets=${TARGETS:-"test_mesher test_fem test_pipeline test_simulation test_bad_inputs test_validation"}
# The validation smoke: Eq. 15 end to end (exact on aligned grids) and the Table I metrics.
validation_filter=${VALIDATION_FILTER:-"Eq15EndToEnd.*:Table1Metrics.*"}

fem_library=""
if [ -n "${FEM_FROM:-}" ]; then
  case " $targets " in *" test_fem "*)
    echo "sanitize.sh: FEM_FROM links an uninstrumented fem; test_fem needs it instrumented (unset FEM_FROM)" >&2
    exit 2 ;;
  esac
  cmake --build "$FEM_FROM" -j"$jobs" --target vim_fem
  fem_library="$FEM_FROM/fem/libvim_fem.a"
fi

checked_targets=${CHECKED_TARGETS-$targets}
# The build dir of each suite: BUILD_DIR for those of CHECKED_TARGETS, BUILD_DIR-unchecked otherwise.
declare -A dir_of
dirs=()
for t in $targets; do
  case " $checked_targets " in *" $t "*) dir_of[$t]="$build" ;; *) dir_of[$t]="$build-unchecked" ;; esac
  case " ${dirs[*]:-} " in *" ${dir_of[$t]} "*) ;; *) dirs+=("${dir_of[$t]}") ;; esac
done
# Release, not RelWithDebInfo: deal_ii_setup_target only knows Debug/Release; -O0 -g1 replace its
# -O3 (CMakeLists.txt also drops the -g -O2 deal.II adds to the targets above fem).
for d in "${dirs[@]}"; do
  checked=ON
  [ "$d" = "$build-unchecked" ] && checked=OFF
  cmake -S "$root" -B "$d" -DCMAKE_BUILD_TYPE=Release -DVIM_SANITIZE=ON -DVIM_CHECKED=$checked -DVIM_BUILD_BENCH=OFF \
    -DCMAKE_CXX_FLAGS="-g1" -DCMAKE_CXX_FLAGS_RELEASE="-O0 -DNDEBUG" -DVIM_FEM_LIBRARY="$fem_library" \
    -DVIM_UNITY_BUILD="$([ "${UNITY:-1}" = 0 ] && echo OFF || echo ON)" \
    ${CMAKE_ARGS:-} >/dev/null
  echo "configured $d (VIM_SANITIZE=ON, VIM_CHECKED=$checked${fem_library:+, fem linked uninstrumented from $fem_library})"
done
[ "${CONFIGURE_ONLY:-0}" = 1 ] && exit 0
declare -A build_seconds
for t in $targets; do
  t0=$(date +%s)
  cmake --build "${dir_of[$t]}" -j"$jobs" --target "$t"
  build_seconds[$t]=$(( $(date +%s) - t0 ))
done

reports_dir="$build/reports"
rm -rf "$reports_dir"
mkdir -p "$reports_dir"
export LSAN_OPTIONS=suppressions="$root/scripts/lsan.supp":print_suppressions=0
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# A GoogleTest filter (POSITIVE[-NEGATIVE]: patterns separated by ':', with * and ?) as an extended
# regular expression over CTest's names of the discovered tests (Suite.Test); empty for no pattern.
filter_regex() {
  [ -n "$1" ] || return 0
  printf '^(%s)$' "$(printf '%s' "$1" | sed -e 's/[].+()|^$[{}\\]/\\&/g' -e 's/\*/.*/g' -e 's/?/./g' -e 's/:/|/g')"
}
# One suite as 2 x JOBS GoogleTest shards, JOBS at a time, in the tests' folder (CTest's working
# directory for them): run_shards DIR SUITE FILTER LOG. Each shard's output goes to LOG.I, then all of
# it to LOG in shard order; a shard that fails or gives no summary makes it fail. No test runs when
# FILTER matches none (an error, as CTest's --no-tests=error).
run_shards() {
  local dir=$1 suite=$2 filter=$3 log=$4 shards=$((2 * jobs)) i rc=0
  local listed
  listed=$("$dir/$suite" --gtest_list_tests --gtest_filter="$filter") || return 1
  if ! grep -q '^  ' <<<"$listed"; then
    echo "run_shards: no test of $suite matches '$filter'" >"$log"
    return 1
  fi
  seq 0 $((shards - 1)) | xargs -P "$jobs" -I{} sh -c \
    'cd "$1" && GTEST_TOTAL_SHARDS=$2 GTEST_SHARD_INDEX=$3 timeout 3600 "./$4" --gtest_filter="$5" >"$6.$3" 2>&1 ||
     { echo "shard $3 of $4 exited with status $?" >>"$6.$3"; exit 1; }' \
    shard "$dir" "$shards" {} "$suite" "$filter" "$log" || rc=1
  : >"$log"
  for i in $(seq 0 $((shards - 1))); do
    cat "$log.$i" >>"$log"
    grep -q '^\[==========\] .* ran\.' "$log.$i" || rc=1
    rm -f "$log.$i"
  done
  return $rc
}
status=0
summary=""
# CTest lists the tests of every built suite (gtest_discover_tests, PRE_TEST) the first time it runs,
# whichever suite it selects: with PER_TEST=1, list them all once here, in each build dir.
for d in "${dirs[@]}"; do
  [ "${PER_TEST:-0}" = 1 ] || break
  set +e
  (cd "$d" &&
    ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:log_path="$reports_dir/discovery" \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:log_path="$reports_dir/discovery" \
    env -u GTEST_FILTER ctest -N) >"$d/discovery.sanitize.log" 2>&1
  rc=$?
  set -e
  reports=$(cat "$reports_dir"/discovery.* 2>/dev/null | grep -cE 'ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer' || true)
  if [ "$rc" -ne 0 ] || [ "$reports" -ne 0 ] || grep -q "Error running test executable" "$d/discovery.sanitize.log"; then
    echo "sanitize.sh: listing the tests failed (log: $d/discovery.sanitize.log)" >&2
    head -c 20000 "$d/discovery.sanitize.log" "$reports_dir"/discovery.* >&2 2>/dev/null || true
    exit 1
  fi
done
for t in $targets; do
  log="${dir_of[$t]}/$t.sanitize.log"
  echo "== $t (log: $log)"
  suite_filter="FILTER_$t"
  filter=${GTEST_FILTER:-${!suite_filter:-*}}
  [ "$t" = test_validation ] && filter=${GTEST_FILTER:-$validation_filter}
  select=(-L "^$t\$")
  include=$(filter_regex "${filter%%-*}")
  [ "$include" = '^(.*)$' ] || [ -z "$include" ] || select+=(-R "$include")
  case "$filter" in *-*) select+=(-E "$(filter_regex "${filter#*-}")") ;; esac
  t0=$(date +%s)
  set +e
  # The stacks of allocations are the fast unwinder's (ASan's default; FAST_UNWIND=0 for full stacks):
  # OpenMPI's plugins stay loaded until exit in a sanitizer build (cmake/keep_libraries_loaded.cpp), so
  # the suppressions name them.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:halt_on_error=1:fast_unwind_on_malloc=${FAST_UNWIND:-1}:log_path="$reports_dir/$t"
  export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:log_path="$reports_dir/$t"
  if [ "${PER_TEST:-0}" = 1 ]; then
    (cd "${dir_of[$t]}" && env -u GTEST_FILTER ctest -j"$jobs" --no-tests=error --output-on-failure "${select[@]}") >"$log" 2>&1
  else
    run_shards "${dir_of[$t]}/tests" "$t" "$filter" "$log"
  fi
  rc=$?
  unset ASAN_OPTIONS UBSAN_OPTIONS
  set -e
  run_seconds=$(( $(date +%s) - t0 ))
  reports=$(cat "$reports_dir/$t".* 2>/dev/null | grep -cE 'ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer' || true)
  [ "$reports" -eq 0 ] || { echo "sanitizer reports of $t:"; head -c 20000 "$reports_dir/$t".*; }
  if [ "${PER_TEST:-0}" = 1 ]; then
    counts=$(grep -oE '[0-9]+ tests failed out of [0-9]+' "$log" | tail -1 || true)
    failed=$(echo "${counts:-0 tests failed out of 0}" | awk '{print $1}')
    passed=$(echo "${counts:-0 tests failed out of 0}" | awk '{print $NF - $1}')
  else
    passed=$({ grep -hoE '^\[  PASSED  \] [0-9]+ test' "$log" || true; } | awk '{s += $4} END {print s + 0}')
    failed=$({ grep -oE '^\[  FAILED  \] [A-Za-z_0-9/]+\.[A-Za-z_0-9/]+' "$log" || true; } | sort -u | wc -l)
  fi
  { [ "$rc" -ne 0 ] || [ "$reports" -ne 0 ]; } && status=1
  summary+=$(printf '%-16s exit %-3s passed %-4s failed %-4s sanitizer reports %-3s build %5s s run %5s s' \
    "$t" "$rc" "$passed" "$failed" "$reports" "${build_seconds[$t]}" "$run_seconds")$'\n'
done
echo "== summary"
printf '%s' "$summary"
[ $status -eq 0 ] && echo "sanitizer run clean" || echo "sanitizer run NOT clean (see logs)"
exit $status

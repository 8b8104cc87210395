#!/usr/bin/env bash
# Builds the libFuzzer targets in fuzz/ (a standalone clang project, not part of the normal build)
# and runs each for SECONDS seconds on a copy of the seed corpus fuzz/corpus/<target>/ (image_header:
# corpus/image, nifti_header: corpus/nifti, scenario, command_line).
#   scripts/fuzz.sh [SECONDS] [BUILD_DIR]      (defaults: 60, ../build-fuzz next to the checkout)
# Environment: JOBS (build parallelism and the number of targets fuzzed at a time, default 1), FUZZ_TARGETS (default "scenario image_header
# nifti_header command_line"), RUNS (stop each target after RUNS executions as well; the reference
# run is `RUNS=1000000 scripts/fuzz.sh 100000`, docs/robustness.md), VIM_BUILD_DIR (a normal build
# whose libraries fuzz_command_line links; default ./build of the checkout). SECONDS is bash's own
# clock, not a parameter: give the time limit as the first argument.
# Crash reproducers are left in BUILD_DIR/artifacts/; exit status 1 if any target found one.
# fuzz/lsan.supp suppresses leaks inside third-party libraries (recorded in docs/robustness.md).
# max_malloc_fill_size=0 and a 16 MB quarantine roughly halve the time per input (ASan otherwise
# fills every allocation and touches fresh pages); each input is still checked by ASan/UBSan/LSan.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-60}
build=${2:-$root/../build-fuzz}
jobs=${JOBS:-1}
targets=${FUZZ_TARGETS:-"scenario image_header nifti_header command_line"}
cxx=${CXX_FUZZ:-$(command -v clang++ || command -v clang++-14)}
cc=${CC_FUZZ:-$(command -v clang || command -v clang-14)}

cmake -S "$root/fuzz" -B "$build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_C_COMPILER="$cc" -DVIM_BUILD_DIR="${VIM_BUILD_DIR:-$root/build}" >/dev/null
for t in $targets; do cmake --build "$build" -j"$jobs" --target "fuzz_$t"; done

mkdir -p "$build/artifacts"
# One target's run (a libFuzzer process is single-threaded): its exit status goes to BUILD_DIR/fuzz_T.rc.
fuzz_one() {
  local t=$1 seeds="$root/fuzz/corpus/${1%_header}" mask=0 corpus="$build/corpus/$1" log="$build/fuzz_$1.log" rc
  # The parser prints --help and usage errors: its stdout and stderr are closed (libFuzzer keeps its own).
  [ "$t" = command_line ] && mask=3
  mkdir -p "$corpus"
  cp -n "$seeds"/* "$corpus"/ 2>/dev/null || true
  set +e
  LSAN_OPTIONS=suppressions="$root/fuzz/lsan.supp" \
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1:max_malloc_fill_size=0:quarantine_size_mb=16 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "$build/fuzz_$t" -max_total_time="$seconds" ${RUNS:+-runs="$RUNS"} -timeout=20 -rss_limit_mb=2048 -max_len=4096 \
    -print_final_stats=1 -close_fd_mask=$mask -artifact_prefix="$build/artifacts/${t}-" "$corpus" >"$log" 2>&1
  rc=$?
  echo "$rc" >"$build/fuzz_$t.rc"
}
# The targets run JOBS at a time, each for SECONDS.
running=0
for t in $targets; do
  echo "== fuzz_$t for ${seconds}s (log: $build/fuzz_$t.log)"
  rm -f "$build/fuzz_$t.rc"
  fuzz_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then wait -n || true; running=$((running - 1)); fi
done
wait
status=0
summary=""
for t in $targets; do
  log="$build/fuzz_$t.log"
  rc=$(cat "$build/fuzz_$t.rc" 2>/dev/null || echo 1)
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  speed=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  crashes=$(ls "$build/artifacts" | grep -c "^${t}-" || true)
  [ "$rc" -ne 0 ] && status=1
  summary+=$(printf '%-20s exit %-3s executions %-10s exec/s %-7s artifacts %s' "fuzz_$t" "$rc" "$execs" "$speed" "$crashes")$'\n'
done
echo "== summary"
printf '%s' "$summary"
exit $status

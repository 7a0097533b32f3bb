#!/usr/bin/env bash
# Fuzzes each libFuzzer target of tests/fuzz for a bounded time, as many at
# once as there are cores, and prints,
# per target, the inputs it executed and the crashes it found; exits 1 when
# any target crashed (a sanitizer report, a failed expectation, an exception
# that should not escape, a timeout or running out of memory).
#
#   tests/fuzz/run_fuzzers.sh [seconds_per_target] [build_dir]
#
# seconds_per_target defaults to 60. Without build_dir it builds the targets
# with `cmake --workflow --preset fuzz` (clang, build-fuzz/) first; a
# build_dir given is used as it is. Each target starts from its seeds in
# tests/fuzz/corpus/<target>/ (read only) and from what earlier runs found,
# kept in <build_dir>/fuzz-corpus/<target>/. A crashing input is saved as
# <build_dir>/fuzz-artifacts/<target>/crash-<sha1>; replay it with
#   <build_dir>/tests/fuzz/fuzz_<target> <that file>
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
seconds=${1:-60}
if [[ ! $seconds =~ ^[1-9][0-9]*$ ]]; then
  echo "run_fuzzers.sh: seconds_per_target must be a positive whole number, got '$seconds'" >&2
  exit 2
fi
if [[ $# -ge 2 ]]; then
  build_dir=$(cd "$2" && pwd)
else
  build_dir=$repo/build-fuzz
  echo "building the fuzz targets: cmake --workflow --preset fuzz" >&2
  (cd "$repo" && cmake --workflow --preset fuzz) >&2
fi

targets=(config route tile_path pmtiles png)
# Leaks count as crashes (libFuzzer's -detect_leaks, on by default);
# UBSan stops at its first report (-fno-sanitize-recover) with a stack.
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# Fuzzes one target; writes its line of the summary to $results/<target> and
# returns non-zero when it crashed.
fuzz_target() {
  local target=$1 exe=$build_dir/tests/fuzz/fuzz_$1
  local corpus=$build_dir/fuzz-corpus/$target artifacts=$build_dir/fuzz-artifacts/$target
  local log=$build_dir/fuzz-logs/$target.log
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  echo "fuzzing $target for ${seconds} s (log: $log)" >&2
  local status=0
  # New inputs go to the first folder only: the seeds stay as they are.
  "$exe" "$corpus" "$repo/tests/fuzz/corpus/$target" \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
    -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1 || status=$?

  # After a crash libFuzzer prints no final stats: take the last "#N" line.
  local runs crashes=0
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  [[ -n $runs ]] || runs=$(grep -o '^#[0-9]*' "$log" | tail -n 1 | tr -d '#')
  if ((status != 0)); then
    crashes=$(grep -c 'Test unit written to' "$log" || true)
    ((crashes > 0)) || crashes=1
    echo "---- $target: exit status $status; the end of its log:" >&2
    tail -n 40 "$log" >&2
  fi
  printf '%-10s %12s executions  %s crashes\n' "$target" "${runs:-0}" "$crashes" >"$results/$target"
  return "$((crashes > 0))"
}

for target in "${targets[@]}"; do
  if [[ ! -x $build_dir/tests/fuzz/fuzz_$target ]]; then
    echo "run_fuzzers.sh: $build_dir/tests/fuzz/fuzz_$target not found; build it: cmake --workflow --preset fuzz" >&2
    exit 2
  fi
done

# One target a core at a time (each fuzzer is single-threaded), so the
# targets share the time without sharing a core.
results=$(mktemp -d)
trap 'rm -rf "$results"' EXIT
jobs=$(nproc)
failed=0
running=0
for target in "${targets[@]}"; do
  if ((running >= jobs)); then
    wait -n || failed=1
    running=$((running - 1))
  fi
  fuzz_target "$target" &
  running=$((running + 1))
done
while ((running > 0)); do
  wait -n || failed=1
  running=$((running - 1))
done

echo "fuzzing, ${seconds} s a target:"
for target in "${targets[@]}"; do
  printf '  %s' "$(cat "$results/$target")"
  echo
done
if ((failed)); then
  echo "run_fuzzers.sh: crashes found; inputs in $build_dir/fuzz-artifacts/" >&2
  exit 1
fi

#!/usr/bin/env bash
# Builds terrabake_bench with the `bench` preset (Release, benchmarks on, in
# build-bench/) and prints milliseconds per tile, each bake backend and the
# double-precision reference against the CPU baker, whole tiles per second,
# and bake throughput with one baking thread and with one per core.
#
#   tests/benchmarks/run_benchmarks.sh [build_dir] [benchmark options...]
#
# Without build_dir it runs `cmake --workflow --preset bench` first, which
# brings build-bench/ up to date (the first build takes several minutes on 2
# cores). A build_dir given is used as it is: configure it with
# -DTERRABAKE_BUILD_BENCHMARKS=ON and build the terrabake_bench target first.
# Options go to terrabake_bench, for example --benchmark_filter=BM_Bake or
# --benchmark_repetitions=5 (the table then shows medians). Timings on a
# shared machine are noisy: compare rows of one run, not runs on different days.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
if [[ $# -gt 0 && $1 != -* ]]; then
  build_dir=$1
  shift
else
  build_dir=$repo/build-bench
  echo "building terrabake_bench: cmake --workflow --preset bench" >&2
  (cd "$repo" && cmake --workflow --preset bench) >&2
fi
bench=$build_dir/tests/benchmarks/terrabake_bench
if [[ ! -x $bench ]]; then
  echo "run_benchmarks.sh: $bench not found; build it: cmake --workflow --preset bench" \
    "(or configure $build_dir with -DTERRABAKE_BUILD_BENCHMARKS=ON and build its terrabake_bench target)" >&2
  exit 1
fi

json=$(mktemp "${TMPDIR:-/tmp}/terrabake_bench.XXXXXX.json")
trap 'rm -f "$json"' EXIT

echo "running $bench (about a minute)..." >&2
"$bench" --benchmark_format=json "$@" >"$json"

# python3 rather than jq: jq is not everywhere, Debian's python3 has json.
/usr/bin/python3 - "$json" <<'PY'
import json
import sys

with open(sys.argv[1]) as f:
    report = json.load(f)

to_ms = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}

def case_name(bench):
    # Drop the settings Google Benchmark appends (/min_time:2.000, /real_time)
    # but the thread count, which tells cases apart: /threads:16 -> /16 threads.
    parts = bench.get("run_name", bench["name"]).split("/")
    threads = [p.split(":")[1] + (" thread" if p == "threads:1" else " threads") for p in parts if p.startswith("threads:")]
    return "/".join([p for p in parts if ":" not in p and p not in ("real_time", "manual_time")] + threads)

# With repetitions the median stands for the case; otherwise its single run.
medians = {case_name(b) for b in report["benchmarks"]
           if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median"}
rows = {}
for b in report["benchmarks"]:
    name = case_name(b)
    if b.get("run_type") == "aggregate":
        if b.get("aggregate_name") != "median":
            continue
    elif name in medians:
        continue
    rows[name] = b

def ms(bench):
    if bench is None or bench.get("error_occurred"):
        return None
    if "items_per_second" in bench:  # threads baking together: wall time per tile of them all
        return 1000 / bench["items_per_second"]
    return bench["real_time"] * to_ms[bench.get("time_unit", "ns")]

def reference_of(name):
    # BM_Bake/osmesa/256 -> BM_Bake/cpu/256, BM_WholeTile/egl -> BM_WholeTile/cpu
    parts = name.split("/")
    if parts[0] not in ("BM_Bake", "BM_WholeTile", "BM_BakeThroughput") or len(parts) < 2:
        return None
    return "/".join([parts[0], "cpu"] + parts[2:])

def versus_cpu(name, time_ms):
    reference = reference_of(name)
    if reference is None or time_ms is None:
        return ""
    if reference == name:
        return "baseline"
    cpu_ms = ms(rows.get(reference))
    if not cpu_ms:
        return "(no cpu row)"
    backend = name.split("/")[1]
    ratio = time_ms / cpu_ms
    if ratio < 1:
        verdict = f"{backend} {1 / ratio:.1f}x faster"
    else:
        verdict = f"cpu {ratio:.1f}x faster"
    return f"{backend}: {ratio:.2f}x cpu time ({verdict})"

def fmt_ms(value):
    return f"{value:.3g}" if value < 10 else f"{value:.1f}"

table = [("case", "ms/tile (real)", "vs the cpu baker, or bytes made", "tiles/s")]
renderers = {}
for name, bench in rows.items():
    time_ms = ms(bench)
    if time_ms is None:
        table.append((name, "skipped", bench.get("error_message", "failed"), ""))
        continue
    tiles_per_s = f"{1000 / time_ms:.1f}" if name.startswith(("BM_WholeTile/", "BM_BakeThroughput/")) else ""
    note = f"{bench['KiB']:.1f} KiB" if "KiB" in bench else versus_cpu(name, time_ms)
    table.append((name, fmt_ms(time_ms), note, tiles_per_s))
    if bench.get("label") and len(name.split("/")) > 1:
        renderers.setdefault(name.split("/")[1], bench["label"])

widths = [max(len(row[i]) for row in table) for i in range(4)]
for k, row in enumerate(table):
    cells = [row[0].ljust(widths[0]), row[1].rjust(widths[1]), row[2].ljust(widths[2]), row[3].rjust(widths[3])]
    print("  ".join(cells).rstrip())
    if k == 0:
        print("  ".join("-" * w for w in widths))

context = report.get("context", {})
print()
print(f"{context.get('num_cpus', '?')} CPUs at {context.get('mhz_per_cpu', '?')} MHz, "
      f"load average {', '.join(f'{x:.2f}' for x in context.get('load_avg', []))}; "
      "256-texel tiles, 17x17 low-poly grid, real (wall-clock) time.")
print("A ratio below 1: that backend is faster than the CPU baker in the same case.")
for backend, label in renderers.items():
    print(f"  {backend}: {label}")
PY

#!/usr/bin/env bash
# Compares low-poly meshers on the same heights and prints one markdown table
# per DEM: the regular grid and the adaptive mesh (mesh_compare, C++), and
# Martini and Delatin (mesh_compare.mjs, node), on nine 256 x 256 windows of
# the bundled sample DEM and of a rough and a flat DEM generated at run time.
#
#   tests/benchmarks/run_mesh_comparison.sh [build_dir] [--repeats N] [--json merged.json]
#
# Without build_dir it configures the `bench` preset and builds mesh_compare
# in build-bench/ (Release). A build_dir given is used as it is: configure it
# with -DTERRABAKE_BUILD_BENCHMARKS=ON and build its mesh_compare target
# first. Martini and Delatin come from tests/node_modules (`npm ci` in
# tests/). --repeats: timed runs per case after a warm-up (default 5, fewer
# once a case has taken half a second); --json also writes every
# per-window number. Takes 2-3 minutes on 2 cores; timings on a shared
# machine are noisy: compare columns of one run.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
if [[ $# -gt 0 && $1 != -* ]]; then
  build_dir=$1
  shift
else
  build_dir=$repo/build-bench
  echo "building mesh_compare: cmake --preset bench && cmake --build build-bench --target mesh_compare" >&2
  (cd "$repo" && cmake --preset bench >/dev/null && cmake --build build-bench --target mesh_compare) >&2
fi
repeats=()
json=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --repeats) repeats=(--repeats "$2"); shift 2 ;;
    --json) json=(--json "$(realpath -m "$2")"); shift 2 ;;
    *) echo "usage: $0 [build_dir] [--repeats N] [--json merged.json]" >&2; exit 2 ;;
  esac
done

compare=$build_dir/tests/benchmarks/mesh_compare
if [[ ! -x $compare ]]; then
  echo "run_mesh_comparison.sh: $compare not found; build it: cmake --preset bench &&" \
    "cmake --build build-bench --target mesh_compare" >&2
  exit 1
fi
for package in @mapbox/martini delatin; do
  if [[ ! -d $repo/tests/node_modules/$package ]]; then
    echo "run_mesh_comparison.sh: $package is not installed; run: (cd tests && npm ci)" >&2
    exit 1
  fi
done

work=$(mktemp -d "${TMPDIR:-/tmp}/terrabake_mesh_compare.XXXXXX")
trap 'rm -rf "$work"' EXIT

echo "meshing with the grid and the adaptive mesher (about a minute)..." >&2
"$compare" "$work" "${repeats[@]}" >/dev/null
echo "meshing with Martini and Delatin (about a minute)..." >&2
node "$repo/tests/benchmarks/mesh_compare.mjs" "$work/results.json" "${repeats[@]}" "${json[@]}"
echo
echo "$(nproc) CPUs, load average $(cut -d' ' -f1-3 /proc/loadavg); node $(node --version)."

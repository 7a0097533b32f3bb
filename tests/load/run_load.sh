#!/usr/bin/env bash
# Load test on loopback: requests per second and latency of the tiles of a
# layer on disk from `terrabake serve` with its tile cache (http.cache_mib at
# its default) and without it (0), as files, as one MBTiles file and as
# PMTiles archives, against nginx serving the same files, taking turns in one
# run; then the latency of tiles baked on demand. Prints a table; fails on any
# request error.
#
#   tests/load/run_load.sh [build_dir] [seconds_per_run] [rounds]
#
# Needs nginx and wrk (Debian: nginx-light wrk); installs them if missing and
# run as root. Traffic stays on 127.0.0.1.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$repo/build}" && pwd)
seconds=${2:-10}
rounds=${3:-2}
terrabake=$build/src/app/terrabake
connections=32
threads=2

for tool in nginx wrk curl; do
  command -v "$tool" >/dev/null && continue
  [ "$(id -u)" = 0 ] || { echo "run_load.sh: $tool is missing (apt-get install nginx-light wrk curl)" >&2; exit 3; }
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends nginx-light wrk curl >/dev/null
done

work=$(mktemp -d /tmp/terrabake-load.XXXXXX)
chmod 755 "$work"  # nginx workers run unprivileged
# Servers started, one pid a line: start_terrabake runs in a command
# substitution's subshell, whose variables the trap would not see.
cleanup() {
  [ -f "$work/pids" ] && while read -r pid; do kill "$pid" 2>/dev/null || true; done <"$work/pids"
  [ -f "$work/nginx.pid" ] && kill "$(cat "$work/nginx.pid")" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

free_port() { /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

# Starts `terrabake serve` with the given arguments; prints its port.
start_terrabake() {
  local log=$work/serve.$RANDOM.out
  "$terrabake" serve --bind 127.0.0.1 --port 0 "$@" >"$log" 2>"$log.err" &
  echo $! >>"$work/pids"
  for _ in $(seq 100); do
    if grep -q "on http://" "$log" 2>/dev/null; then
      sed -n 's|.*on http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$log"
      return
    fi
    sleep 0.1
  done
  echo "run_load.sh: terrabake serve did not start: $(cat "$log.err")" >&2
  exit 1
}

echo "run_load.sh: making the sample layer..." >&2
"$terrabake" tile --config "$repo/config/sample.yaml" --out "$work/tiles" >/dev/null 2>&1
# The same layer as $work/mbtiles/sample.mbtiles and as $work/pmtiles/sample*.pmtiles: its tiles have the same URLs.
for format in mbtiles pmtiles; do
  "$terrabake" tile --config "$repo/config/sample.yaml" --out "$work/$format" --format "$format" >/dev/null 2>&1
done
(cd "$work/tiles" && find sample -name '*.png' -o -name '*.glb' | sed 's|^|/|' | sort) >"$work/paths.txt"
export TILE_LIST=$work/paths.txt

cached_port=$(start_terrabake --tiles "$work/tiles")
uncached_port=$(start_terrabake --tiles "$work/tiles" --cache-mib 0)
mbtiles_cached_port=$(start_terrabake --tiles "$work/mbtiles")
mbtiles_uncached_port=$(start_terrabake --tiles "$work/mbtiles" --cache-mib 0)
pmtiles_cached_port=$(start_terrabake --tiles "$work/pmtiles")
pmtiles_uncached_port=$(start_terrabake --tiles "$work/pmtiles" --cache-mib 0)

nginx_port=$(free_port)
mkdir -p "$work/nginx"
cat >"$work/nginx.conf" <<CONF
worker_processes $threads;
pid $work/nginx.pid;
error_log $work/nginx/error.log;
events { worker_connections 1024; }
http {
  access_log off;
  sendfile on;
  types { image/png png; model/gltf-binary glb; application/json json; }
  client_body_temp_path $work/nginx; proxy_temp_path $work/nginx; fastcgi_temp_path $work/nginx;
  uwsgi_temp_path $work/nginx; scgi_temp_path $work/nginx;
  server {
    listen 127.0.0.1:$nginx_port;
    root $work/tiles;
    add_header Access-Control-Allow-Origin *;
    add_header Cache-Control "public, max-age=3600";
  }
}
CONF
nginx -c "$work/nginx.conf" -p "$work/nginx"
for _ in $(seq 50); do curl -fs -o /dev/null "http://127.0.0.1:$nginx_port$(head -1 "$TILE_LIST")" && break; sleep 0.1; done

# One pass over every file first, so every server answers from the page cache
# (and terrabake's tile cache holds every tile when it is on).
run_wrk() {
  local port=$1
  while read -r path; do curl -fs -o /dev/null "http://127.0.0.1:$port$path"; done <"$TILE_LIST"
  wrk -t"$threads" -c"$connections" -d"${seconds}s" --latency -s "$repo/tests/load/tile_paths.lua" \
    "http://127.0.0.1:$port" | sed -n 's/^RESULT //p'
}

# Turns: each server once per round, so drift on a shared machine hits all alike.
for round in $(seq "$rounds"); do
  for server in cached:$cached_port uncached:$uncached_port mbtiles_cached:$mbtiles_cached_port \
    mbtiles_uncached:$mbtiles_uncached_port pmtiles_cached:$pmtiles_cached_port \
    pmtiles_uncached:$pmtiles_uncached_port nginx:$nginx_port; do
    echo "run_load.sh: round $round, ${server%%:*}..." >&2
    echo "${server%%:*} $(run_wrk "${server#*:}")" >>"$work/results.txt"
  done
done

# On demand: a fresh server whose sample layer is empty, asked for every
# zoom-12 tile once, one request at a time; each answer is a bake.
mkdir -p "$work/on_demand"
cat >"$work/serve.yaml" <<YAML
tiles: $work/on_demand
layers: [$repo/config/sample.yaml]
YAML
on_demand_port=$(start_terrabake --config "$work/serve.yaml")
grep '/sample/12/.*\.png$' "$TILE_LIST" >"$work/on_demand_paths.txt"
while read -r path; do
  curl -fs -o /dev/null -w '%{time_total}\n' "http://127.0.0.1:$on_demand_port$path" ||
    { echo "run_load.sh: on-demand request failed: $path" >&2; exit 1; }
done <"$work/on_demand_paths.txt" >"$work/on_demand_times.txt"

/usr/bin/python3 - "$work/results.txt" "$work/on_demand_times.txt" "$seconds" "$connections" <<'PY'
import statistics
import sys

NAMES = {"cached": "terrabake, files, cache on", "uncached": "terrabake, files, cache off",
         "mbtiles_cached": "terrabake, MBTiles, cache on", "mbtiles_uncached": "terrabake, MBTiles, cache off",
         "pmtiles_cached": "terrabake, PMTiles, cache on", "pmtiles_uncached": "terrabake, PMTiles, cache off",
         "nginx": "nginx, files"}
runs = {name: [] for name in NAMES}
for line in open(sys.argv[1]):
    name, *items = line.split()
    runs[name].append({k: float(v) for k, v in (item.split("=") for item in items)})
times_ms = sorted(float(line) * 1000 for line in open(sys.argv[2]))
seconds, connections = sys.argv[3], sys.argv[4]
print(f"tiles on disk: wrk, {connections} connections, 2 threads, {seconds} s each, loopback, servers taking turns")
print(f"{'server':<32}{'requests/s':>12}{'p50 ms':>10}{'p99 ms':>10}{'errors':>8}")
for name, label in NAMES.items():
    for r in runs[name]:
        print(f"{label:<32}{r['rps']:>12.0f}{r['p50_ms']:>10.2f}{r['p99_ms']:>10.2f}{int(r['errors']):>8}")
mean = {name: statistics.mean(r["rps"] for r in rs) for name, rs in runs.items()}
for name in NAMES:
    if name == "nginx":
        continue
    print(f"{NAMES[name]} / nginx: {mean[name] / mean['nginx']:.2f}x the requests per second (means of the runs)")
p99 = times_ms[min(len(times_ms) - 1, int(len(times_ms) * 0.99))]
print(f"on-demand tiles (baked per request, one at a time): {len(times_ms)} tiles, "
      f"median {statistics.median(times_ms):.0f} ms, p99 {p99:.0f} ms, max {times_ms[-1]:.0f} ms")
sys.exit(1 if any(r["errors"] for rs in runs.values() for r in rs) else 0)
PY

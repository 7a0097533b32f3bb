#!/usr/bin/python3
"""Tiles a big DEM and prints tiles per second and peak memory per worker count.

The DEM is a VRT that repeats the bundled 1024 x 1024 sample R x R times, so
it costs nothing on disk while GDAL sees (1024 R)^2 pixels and no overviews.

    tests/scale/big_dem.py [--build DIR] [--repeats R] [--zoom Z] [--workers N,M,...]
                           [--max-rss-mib MIB]

    # the two measurements the README reports ("Scale"):
    tests/scale/big_dem.py --repeats 8 --zoom auto --workers 1,2      # 8192^2 pyramid
    tests/scale/big_dem.py --repeats 40 --zoom 4-8 --max-rss-mib 2048  # 40960^2, memory bound

Exits 1 when a run fails or peaks above --max-rss-mib.
"""
import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile

from repeated_sample import write_vrt

repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--build", default=os.path.join(repo, "build"))
parser.add_argument("--repeats", type=int, default=8)
parser.add_argument("--zoom", default="auto")
parser.add_argument("--workers", default="1,2")
parser.add_argument("--max-rss-mib", type=float, default=None)
args = parser.parse_args()


def run(vrt, out, workers):
    """One run in a child of its own, so its peak RSS is its alone."""
    command = [os.path.join(args.build, "src", "app", "terrabake"), "tile", "--dem", vrt, "--zoom", args.zoom,
               "--out", out, "--layer", f"w{workers}", "--workers", str(workers)]
    probe = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
             "print(r.stdout, end=''); print(r.stderr[-2000:], file=sys.stderr, end=''); "
             "print('PEAK_KB', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(r.returncode)")
    result = subprocess.run([sys.executable, "-c", probe] + command, capture_output=True, text=True)
    peak_mib = int(re.search(r"PEAK_KB (\d+)", result.stdout).group(1)) / 1024
    summary = re.search(r"wrote (\d+) tiles .*\((\d+) skipped, (\d+) empty, (\d+) failed\) in ([0-9.]+) s",
                        result.stdout)
    if result.returncode != 0 or not summary:
        print(result.stdout + result.stderr, file=sys.stderr)
        sys.exit(result.returncode or 1)
    written, _, empty, failed, seconds = summary.groups()
    return int(written), int(empty), float(seconds), peak_mib


with tempfile.TemporaryDirectory(prefix="terrabake-scale-") as work:
    vrt = os.path.join(work, "dem.vrt")
    size = write_vrt(vrt, args.repeats)
    print(f"{size} x {size} pixel DEM (30 m, no overviews), zoom {args.zoom}")
    print(f"{'workers':>8}{'tiles':>8}{'empty':>7}{'seconds':>10}{'tiles/s':>9}{'peak MiB':>10}")
    over = False
    for workers in (int(w) for w in args.workers.split(",")):
        written, empty, seconds, peak = run(vrt, os.path.join(work, "tiles"), workers)
        print(f"{workers:>8}{written:>8}{empty:>7}{seconds:>10.1f}{written / seconds:>9.1f}{peak:>10.0f}", flush=True)
        over |= args.max_rss_mib is not None and peak > args.max_rss_mib
    sys.exit(1 if over else 0)

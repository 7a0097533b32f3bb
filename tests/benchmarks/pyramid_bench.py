#!/usr/bin/python3
"""Whole-pyramid throughput: terrabake per backend against the GDAL chain, in one run.

    tests/benchmarks/pyramid_bench.py [--build DIR] [--size PIXELS] [--zoom 8-14] [--workers 2]
                                      [--backends cpu,osmesa] [--rounds N] [--per-zoom REPEATS] [--keep DIR]

1. Pyramid: the bundled sample DEM warped to EPSG:3857 (--size x --size
   pixels, Float32, cubic), tiled over --zoom by
   - the GDAL chain a user runs for shaded tiles: `gdaldem hillshade` then
     `gdal2tiles.py --processes N` (grey shading only, no mesh);
   - `terrabake tile --backend B --workers N` for each backend.
   It prints tiles/s, the ratio to the GDAL chain, peak memory (RSS of the
   process tree's largest process) and terrabake's per-stage milliseconds per
   tile (the workers' time, from its `time per tile` log line). It also
   prints the CPU time each run took (user and system, the process tree's)
   and that ratio: other load on a shared machine stretches wall time far
   more than CPU time. With --rounds N the runs take turns N times, each
   ratio against the GDAL run of its own round, and a last table gives the
   medians.
2. With --per-zoom R: a DEM of (1024 R)^2 pixels without overviews (a VRT
   repeating the sample, so nothing on disk), tiled zoom by zoom from the one
   where it fits a tile to the deepest `auto` picks, one worker; each zoom is
   limited to about --max-tiles tiles round the DEM's centre. It prints the mean time per tile
   of each zoom and its ratio to the deepest zoom's with as many tiles, run next to it.
   With --rounds N each zoom and its reference take turns N times (every other round the
   reference first), and the table gives the medians (the ratio: the median of the rounds'
   ratios).

Every run writes into a folder no other run used, and the folders are removed
when the script ends. Timings on a shared machine are noisy: compare rows of
one run.
"""
import argparse
import collections
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(repo, "tests", "scale"))
from repeated_sample import ORIGIN_X, ORIGIN_Y, PIXEL_M, SAMPLE, SAMPLE_PIXELS, write_vrt  # noqa: E402
parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--build", default=os.path.join(repo, "build"))
parser.add_argument("--size", type=int, default=4096)
parser.add_argument("--zoom", default="8-14")
parser.add_argument("--workers", type=int, default=2)
parser.add_argument("--backends", default="cpu,osmesa")
parser.add_argument("--rounds", type=int, default=1, help="runs taking turns this many times")
parser.add_argument("--per-zoom", type=int, default=0, metavar="REPEATS")
parser.add_argument("--max-tiles", type=int, default=48)
parser.add_argument("--keep", default=None, help="work in this folder and keep it (the DEM; the tiles go at the end)")
args = parser.parse_args()

terrabake = os.path.join(args.build, "src", "app", "terrabake")
SAMPLE_INNER_LON_LAT = ("9.81", "46.37", "10.19", "46.63")  # west south east north, inside its data

# Runs a command in a child of its own and returns (seconds, peak RSS MiB, CPU seconds, stdout + stderr).
PROBE = ("import resource, subprocess, sys, time; t = time.monotonic(); "
         "r = subprocess.run(sys.argv[1:], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True); "
         "print(r.stdout, end=''); u = resource.getrusage(resource.RUSAGE_CHILDREN); "
         "print('PROBE', time.monotonic() - t, u.ru_maxrss, u.ru_utime + u.ru_stime); "
         "sys.exit(r.returncode)")


def measured(command, env=None):
    result = subprocess.run([sys.executable, "-c", PROBE] + command, capture_output=True, text=True, env=env)
    probe = re.search(r"PROBE ([0-9.]+) (\d+) ([0-9.]+)\s*$", result.stdout)
    if result.returncode != 0 or not probe:
        print(" ".join(command) + " failed:\n" + result.stdout[-3000:] + result.stderr[-2000:], file=sys.stderr)
        sys.exit(1)
    return float(probe.group(1)), int(probe.group(2)) / 1024, float(probe.group(3)), result.stdout


def output_folder(name):
    """A folder of its own for one run's files. A run into the folder of an earlier one would pay for freeing the
    files it replaces (on a file system mounted with discard, as this machine's is, that costs a run about a tenth of
    its time), which neither a user's first run nor one into a folder just emptied, as the GDAL chain's was, pays.
    The folders go when the script ends, after every timed run."""
    output_folder.count += 1
    return os.path.join(OUTPUTS, f"{output_folder.count:03d}-{name}")


output_folder.count = 0


def count_files(folder, suffix):
    return sum(1 for _, _, files in os.walk(folder) for f in files if f.endswith(suffix))


def terrabake_run(dem, out, layer, zoom, backend, extra=(), workers=None):
    command = [terrabake, "tile", "--dem", dem, "--zoom", zoom, "--out", out, "--layer", layer,
               "--workers", str(workers or args.workers), "--backend", backend, *extra]
    seconds, peak, cpu, output = measured(command)
    summary = re.search(r"wrote (\d+) tiles .*\((\d+) skipped, (\d+) empty, (\d+) failed\) in ([0-9.]+) s", output)
    if not summary or int(summary.group(4)) != 0:
        print(output[-3000:], file=sys.stderr)
        sys.exit(1)
    stages = re.search(r"time per tile, in the workers: (.*)", output)
    return int(summary.group(1)), seconds, peak, cpu, stages.group(1).strip() if stages else ""


# One run of the GDAL chain or of a backend: tiles/s in `rate`, tiles per CPU second in `cpu_rate`, peak
# RSS in MiB, terrabake's stages line.
Run = collections.namedtuple("Run", "name tiles seconds rate cpu cpu_rate peak stages")


def pyramid_round(dem):
    """One run of the GDAL chain and then of each backend, as Runs."""
    rows = []
    chain = output_folder("gdal")
    os.makedirs(chain)
    shade = os.path.join(chain, "hillshade.tif")
    gdal_out = os.path.join(chain, "gdal2tiles")
    t_shade, peak_shade, cpu_shade, _ = measured(["gdaldem", "hillshade", "-q", "-compute_edges", dem, shade])
    t_tiles, peak_tiles, cpu_tiles, _ = measured(["gdal2tiles.py", "-q", f"--processes={args.workers}", "-z", args.zoom,
                                       "-w", "none", "-r", "average", "--xyz", shade, gdal_out])
    gdal_tiles = count_files(gdal_out, ".png")
    seconds, cpu = t_shade + t_tiles, cpu_shade + cpu_tiles
    rows.append(Run("gdaldem hillshade + gdal2tiles", gdal_tiles, seconds, gdal_tiles / seconds, cpu, gdal_tiles / cpu,
                    max(peak_shade, peak_tiles), ""))
    for backend in args.backends.split(","):
        tiles, seconds, peak, cpu, stages = terrabake_run(dem, output_folder(backend), backend, args.zoom, backend)
        rows.append(Run(f"terrabake --backend {backend}", tiles, seconds, tiles / seconds, cpu, tiles / cpu, peak,
                        stages))
    return rows


def pyramid(work):
    dem = os.path.join(work, "dem3857.tif")
    # The sample's lon/lat box less a margin, so that every pixel holds data.
    subprocess.run(["gdalwarp", "-q", "-overwrite", "-t_srs", "EPSG:3857", "-te_srs", "EPSG:4326",
                    "-te", *SAMPLE_INNER_LON_LAT, "-ts", str(args.size), str(args.size), "-r", "cubic",
                    "-ot", "Float32", "-co", "TILED=YES", SAMPLE, dem], check=True)
    print(f"Pyramid: {args.size} x {args.size} EPSG:3857 DEM (the sample, warped), zooms {args.zoom}, "
          f"{args.workers} workers or processes each")
    rounds = []
    for number in range(1, args.rounds + 1):
        rows = pyramid_round(dem)
        rounds.append(rows)
        gdal = rows[0]
        if args.rounds > 1:
            print(f"\nround {number} of {args.rounds}")
        print(f"{'run':<34}{'tiles':>7}{'seconds':>9}{'tiles/s':>9}{'vs GDAL':>9}{'CPU s':>8}{'vs GDAL':>9}"
              f"{'peak MiB':>10}")
        for run in rows:
            print(f"{run.name:<34}{run.tiles:>7}{run.seconds:>9.2f}{run.rate:>9.1f}{run.rate / gdal.rate:>8.2f}x"
                  f"{run.cpu:>8.2f}{run.cpu_rate / gdal.cpu_rate:>8.2f}x{run.peak:>10.0f}")
        print("vs GDAL: tiles/s, then tiles per CPU second, against the GDAL chain's")
        print("\nterrabake, milliseconds per tile by stage (summed over the workers):")
        for run in rows[1:]:
            print(f"  {run.name:<32}{run.stages}", flush=True)
    if args.rounds > 1:
        print(f"\nmedians of {args.rounds} rounds (each ratio against its own round's GDAL run)")
        print(f"{'run':<34}{'tiles/s':>9}{'vs GDAL':>9}{'CPU s':>8}{'vs GDAL':>9}{'peak MiB':>10}")
        for k, first in enumerate(rounds[0]):
            rate = statistics.median(each[k].rate for each in rounds)
            ratio = statistics.median(each[k].rate / each[0].rate for each in rounds)
            cpu = statistics.median(each[k].cpu for each in rounds)
            cpu_ratio = statistics.median(each[k].cpu_rate / each[0].cpu_rate for each in rounds)
            peak = max(each[k].peak for each in rounds)
            print(f"{first.name:<34}{rate:>9.1f}{ratio:>8.2f}x{cpu:>8.2f}{cpu_ratio:>8.2f}x{peak:>10.0f}")


def lon_lat_of_centre(repeats):
    from osgeo import osr
    utm = osr.SpatialReference()
    utm.ImportFromEPSG(32632)
    wgs84 = osr.SpatialReference()
    wgs84.ImportFromEPSG(4326)
    wgs84.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    half = repeats * SAMPLE_PIXELS * PIXEL_M / 2
    lon, lat, _ = osr.CoordinateTransformation(utm, wgs84).TransformPoint(ORIGIN_X + half, ORIGIN_Y - half)
    return lon, lat


def zoom_range(vrt):
    """The webmercator zooms `terrabake info` gives: from where the DEM fits one tile to auto's."""
    output = subprocess.run([terrabake, "info", vrt], capture_output=True, text=True).stdout
    match = re.search(r"webmercator +(\d+)-(\d+)", output)
    if not match:
        sys.exit("pyramid_bench.py: `terrabake info` gave no webmercator zooms:\n" + output)
    return int(match.group(1)), int(match.group(2))


def per_zoom(work):
    vrt = os.path.join(work, "big.vrt")
    size = write_vrt(vrt, args.per_zoom)
    lon, lat = lon_lat_of_centre(args.per_zoom)
    shallowest, deepest = zoom_range(vrt)
    print(f"\nPer zoom: {size} x {size} DEM without overviews (30 m, EPSG:32632), zooms {shallowest}-{deepest}, "
          f"at most about {args.max_tiles} tiles round the centre each, backend cpu"
          + (f"; medians of {args.rounds} rounds, the largest peak" if args.rounds > 1 else ""))
    print(f"{'zoom':>5}{'tiles':>7}{'run s':>8}{'ms/tile':>9}{'deepest, as many tiles':>24}{'ratio':>7}"
          f"{'peak MiB':>10}")

    def run_zoom(z, budget):
        """ms per tile (all stages, the workers' time) of about `budget` tiles of zoom z round the centre."""
        tile_deg = 360.0 / 2 ** z  # a webmercator tile's width; its height at lat is cos(lat) of it
        half_deg = tile_deg * math.sqrt(budget) / 2 * 0.999
        half_lat = half_deg * math.cos(math.radians(lat))
        bbox = f"{max(lon - half_deg, -180)},{max(lat - half_lat, -85)},{min(lon + half_deg, 180)}," \
               f"{min(lat + half_lat, 85)}"
        tiles, seconds, peak, _, stages = terrabake_run(vrt, output_folder(f"z{z}"), f"z{z}", str(z), "cpu",
                                                     ["--bbox", bbox], workers=1)
        return tiles, seconds, sum(float(v) for v in re.findall(r"([0-9.]+) ms", stages)), peak

    # Each zoom against the deepest zoom with as many tiles, so that what a
    # worker does on its first tile (opening files, GDAL's caches) weighs the
    # same, run next to it, so that both meet the same load on the machine;
    # every other round the reference runs first.
    for z in range(shallowest, deepest + 1):
        rounds = []
        tiles = None
        for turn in range(args.rounds):
            if turn % 2 and tiles is not None:
                reference = run_zoom(deepest, tiles)[2]
                tiles, seconds, ms, peak = run_zoom(z, args.max_tiles)
            else:
                tiles, seconds, ms, peak = run_zoom(z, args.max_tiles)
                reference = run_zoom(deepest, tiles)[2]
            rounds.append((seconds, ms, reference, ms / reference, peak))
        seconds, ms, reference, ratio, _ = (statistics.median(column) for column in zip(*rounds))
        peak = max(r[4] for r in rounds)
        print(f"{z:>5}{tiles:>7}{seconds:>8.2f}{ms:>9.1f}{reference:>24.1f}{ratio:>6.2f}x{peak:>10.0f}", flush=True)
    print("ms/tile: the worker's time per tile (1 worker), all stages (terrabake's `time per tile` line); run s: the\n"
          "whole run's wall time, with what it does once (opening the DEM, making its reduced levels, the backdrop).")


with tempfile.TemporaryDirectory(prefix="terrabake-pyramid-") as tmp:
    work = args.keep or tmp
    os.makedirs(work, exist_ok=True)
    OUTPUTS = tempfile.mkdtemp(prefix="outputs-", dir=work)
    try:
        pyramid(work)
        if args.per_zoom:
            per_zoom(work)
    finally:
        shutil.rmtree(OUTPUTS, ignore_errors=True)

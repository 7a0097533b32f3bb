#!/usr/bin/python3
"""Peak memory of tiling a 40960 x 40960 pixel DEM (issue: stays under 2 GiB).

The DEM is a VRT that repeats the bundled 1024 x 1024 sample 40 x 40 times,
so it costs nothing on disk while GDAL sees 1.7 billion pixels and no
overviews: every low-zoom tile averages a huge source area. Prints the run's
summary and its peak resident memory; exits 1 over the bound.

    tests/scale/memory_40k.py [build_dir] [min_zoom-max_zoom]
"""
import os
import resource
import subprocess
import sys
import tempfile

REPEATS = 40
SAMPLE_PIXELS = 1024
PIXEL_M = 30.0
LIMIT_BYTES = 2 * 1024**3

repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(repo, "build"))
zooms = sys.argv[2] if len(sys.argv) > 2 else "4-8"
sample = os.path.join(repo, "tests", "data", "sample_dem.tif")
# The sample's own origin (EPSG:32632), so the mosaic starts where it does.
ORIGIN_X, ORIGIN_Y = 561360.0, 5165460.0


def write_vrt(path):
    size = REPEATS * SAMPLE_PIXELS
    sources = []
    for row in range(REPEATS):
        for col in range(REPEATS):
            sources.append(
                f'<SimpleSource><SourceFilename relativeToVRT="0">{sample}</SourceFilename>'
                f'<SourceBand>1</SourceBand>'
                f'<SrcRect xOff="0" yOff="0" xSize="{SAMPLE_PIXELS}" ySize="{SAMPLE_PIXELS}"/>'
                f'<DstRect xOff="{col * SAMPLE_PIXELS}" yOff="{row * SAMPLE_PIXELS}" '
                f'xSize="{SAMPLE_PIXELS}" ySize="{SAMPLE_PIXELS}"/></SimpleSource>')
    with open(path, "w") as f:
        f.write(f'<VRTDataset rasterXSize="{size}" rasterYSize="{size}">'
                f'<SRS>EPSG:32632</SRS>'
                f'<GeoTransform>{ORIGIN_X}, {PIXEL_M}, 0, {ORIGIN_Y}, 0, {-PIXEL_M}</GeoTransform>'
                f'<VRTRasterBand dataType="Int16" band="1">{"".join(sources)}</VRTRasterBand>'
                f'</VRTDataset>\n')
    return size


with tempfile.TemporaryDirectory(prefix="terrabake-memory-") as work:
    vrt = os.path.join(work, "dem_40k.vrt")
    size = write_vrt(vrt)
    command = [os.path.join(build, "src", "app", "terrabake"), "tile", "--dem", vrt, "--zoom", zooms,
               "--out", os.path.join(work, "tiles"), "--layer", "big"]
    print(f"memory_40k: {size} x {size} pixels, zooms {zooms}: {' '.join(command)}", flush=True)
    result = subprocess.run(command, capture_output=True, text=True)
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024  # kilobytes on Linux
    print(result.stdout.strip())
    if result.returncode != 0:
        print(result.stderr.strip()[-2000:])
        sys.exit(result.returncode)
    print(f"peak resident memory: {peak / 1024**2:.0f} MiB (bound {LIMIT_BYTES / 1024**2:.0f} MiB)")
    sys.exit(0 if peak < LIMIT_BYTES else 1)

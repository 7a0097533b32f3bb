"""A big DEM for nothing on disk: a VRT that repeats the bundled 1024 x 1024
sample (30 m, EPSG:32632) R x R times, so GDAL sees (1024 R)^2 pixels and no
overviews. Shared by tests/scale/big_dem.py and tests/benchmarks/pyramid_bench.py."""
import os

SAMPLE_PIXELS = 1024
PIXEL_M = 30.0
# The sample's own origin (EPSG:32632), so the mosaic starts where it does.
ORIGIN_X, ORIGIN_Y = 561360.0, 5165460.0
SAMPLE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "sample_dem.tif")


def write_vrt(path, repeats):
    """Writes the VRT; returns its width (and height) in pixels."""
    size = repeats * SAMPLE_PIXELS
    sources = "".join(
        f'<SimpleSource><SourceFilename relativeToVRT="0">{SAMPLE}</SourceFilename>'
        f'<SourceBand>1</SourceBand>'
        f'<SrcRect xOff="0" yOff="0" xSize="{SAMPLE_PIXELS}" ySize="{SAMPLE_PIXELS}"/>'
        f'<DstRect xOff="{col * SAMPLE_PIXELS}" yOff="{row * SAMPLE_PIXELS}" '
        f'xSize="{SAMPLE_PIXELS}" ySize="{SAMPLE_PIXELS}"/></SimpleSource>'
        for row in range(repeats) for col in range(repeats))
    with open(path, "w") as f:
        f.write(f'<VRTDataset rasterXSize="{size}" rasterYSize="{size}"><SRS>EPSG:32632</SRS>'
                f'<GeoTransform>{ORIGIN_X}, {PIXEL_M}, 0, {ORIGIN_Y}, 0, {-PIXEL_M}</GeoTransform>'
                f'<VRTRasterBand dataType="Int16" band="1">{sources}</VRTRasterBand></VRTDataset>\n')
    return size

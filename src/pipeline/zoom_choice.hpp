#pragma once
// Which zooms suit a DEM, and where it lies in a scheme's CRS: `tiling.zoom:
// auto`, the job's plan and `terrabake info` all ask.
#include <string>
#include <vector>

#include "core/types.hpp"
#include "dem/dem_source.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::pipeline {

// Ground size in metres of a cell_w x cell_h cell of `crs` centred on (x, y):
// the square root of its area, so cells that are not square on the ground
// (geodetic ones away from the equator) compare by area.
double cellGroundSizeM(const std::string& crs, double x, double y, double cell_w, double cell_h);

// The ground size of a DEM pixel at the centre of the DEM.
double demPixelSizeM(const dem::DemSource& dem);

// The DEM's lon/lat box within latitudes +-max_lat_deg (a scheme's) as
// pieces that each lie within -180..180: two when it crosses the
// antimeridian (GDAL gives west > east then, or a longitude beyond 180 for a
// geographic DEM stored past it), one of 360 degrees round the whole globe,
// none when no latitude is left.
std::vector<Extent> lonLatPieces(const Extent& box, double max_lat_deg);

// Where the DEM lies in the scheme's CRS, as a job plans it: its extent, or
// across the antimeridian the pieces either side (the first, east of it,
// judges the zooms); none when it lies beyond the scheme's latitudes.
std::vector<Extent> demAreas(const tiling::Scheme& scheme, const dem::DemSource& dem);

// The same for each of the DEM's files, merged where they meet: one area
// for a mosaic, and one for each file or group of neighbours of a list of
// files far apart, so that the tiles between them are not planned.
std::vector<Extent> fileAreas(const tiling::Scheme& scheme, const dem::DemSource& dem);

// The deepest zoom whose texels, at the centre of `area` (the DEM in the
// scheme's CRS), are no smaller than the DEM's pixels; 0 when even zoom 0's
// are smaller. Native: the full-resolution level.
int autoMaxZoom(const tiling::Scheme& scheme, const Extent& area, const dem::DemSource& dem);

// The deepest zoom up to `max_zoom` at which one tile covers `area`; 0 when
// no zoom does (an area across a zoom-0 tile edge).
int oneTileZoom(const tiling::Scheme& scheme, const Extent& area, int max_zoom);

}  // namespace terrabake::pipeline

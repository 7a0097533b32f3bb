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

// The ground size of a pixel of some of the DEM's files (indices in the
// order given) at the centre of their grid (DemSource::gridOf).
double pixelSizeM(const dem::DemSource& dem, const std::vector<std::size_t>& files);

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

// Where a group of the DEM's files that meet lies in the scheme's CRS, and
// the files judged there: those whose first area (of the first part of a
// VRT of scattered sources, east of the antimeridian for one across it)
// lies in it.
struct FileGroup {
  Extent area;
  std::vector<std::size_t> files;  // none for a group of a file's other parts alone
};

// The areas of the DEM's files' parts (DemSource::filePartBoundsIn, as
// demAreas works them out for the DEM), merged where they meet: one group
// for a mosaic, and one for each file, part or group of neighbours far
// apart, so that the tiles between them are not planned, and each file's
// zooms and reads are judged where it lies, as a job of it alone judges
// them.
std::vector<FileGroup> fileGroups(const tiling::Scheme& scheme, const dem::DemSource& dem);

// The groups' areas.
std::vector<Extent> groupAreas(const std::vector<FileGroup>& groups);

// The group whose area judges `file`: its own, or the first that judges any
// file for a file beyond the scheme's latitudes.
std::size_t groupJudging(const std::vector<FileGroup>& groups, std::size_t file);

// The deepest zoom whose texels, at the centre of `area`, are no smaller
// than `pixel_m`; 0 when even zoom 0's are smaller. Native: the
// full-resolution level.
int autoMaxZoom(const tiling::Scheme& scheme, const Extent& area, double pixel_m);

// The deepest zoom that suits any group of files: each group's choice, at
// the centre of its area for the pixels of its files.
int autoMaxZoom(const tiling::Scheme& scheme, const std::vector<FileGroup>& groups, const dem::DemSource& dem);

// The deepest zoom up to `max_zoom` at which one tile covers `area`; 0 when
// no zoom does (an area across a zoom-0 tile edge).
int oneTileZoom(const tiling::Scheme& scheme, const Extent& area, int max_zoom);

}  // namespace terrabake::pipeline

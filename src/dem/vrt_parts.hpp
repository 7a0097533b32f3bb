#pragma once
// Where a VRT's sources put data. A VRT of scattered tiles (islands, the
// land tiles of a world DEM) is mostly empty, and a job plans only the
// tiles round its parts rather than every tile of its extent.
#include <gdal_priv.h>

#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

// The box each of band `band`'s VRT sources covers within the raster, in
// pixels (x right, y down), in the order drawn; none for a raster that is
// not a VRT of sources that each say where they lie.
std::vector<Extent> vrtSourceBoxes(GDALDataset& dataset, int band);

// The boxes of band `band`'s VRT sources within the raster, in its
// georeferenced coordinates, merged where they meet (mergeMeeting), the
// largest first. None
// for a raster that is not a VRT of sources that each say where they lie
// (a warped VRT, say): such a raster is one part, its whole extent.
std::vector<Extent> vrtSourceParts(GDALDataset& dataset, int band);

}  // namespace terrabake::dem

#pragma once
// GDAL helpers shared by the dem module's files (GDAL types stay inside dem).
#include <ogr_spatialref.h>

#include <string>

namespace terrabake::dem {

// Registers drivers and routes GDAL's messages to our log instead of stderr,
// so that errors reach the user once, as our own one-line messages. Call
// before any GDAL use; later calls do nothing.
void ensureGdalReady();

// Holds GDAL's block cache to what `readers` reading at once need (16 MiB
// each, 32 MiB to 256 MiB in all; 256 MiB until called). GDAL_CACHEMAX in
// the environment wins.
void sizeBlockCacheFor(int readers);

// GDAL's last error message on one line, or a placeholder when it has none.
std::string lastGdalError();

// A CRS from any definition GDAL accepts (WKT, "EPSG:n", ...), with x as
// longitude or easting. Throws InputError for one it does not know.
OGRSpatialReference spatialReference(const std::string& crs);

std::string toWkt(const OGRSpatialReference& srs);

}  // namespace terrabake::dem

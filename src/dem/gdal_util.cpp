#include "dem/gdal_util.hpp"

#include <cpl_conv.h>
#include <gdal.h>

#include <algorithm>
#include <mutex>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::dem {
namespace {

void CPL_STDCALL routeGdalMessage(CPLErr level, CPLErrorNum, const char* message) {
  // Failures are reported by the caller with CPLGetLastErrorMsg(); warnings
  // are detail a user asks for with --verbose.
  if (level == CE_Warning) log::debug(std::string("gdal: ") + message);
}

// GDAL's block cache. Each reader reads through handles of its own, so the
// cache holds every reader's blocks apart, and each block it takes in is
// fresh memory the system must map: a smaller cache reuses that memory. A
// few tile windows per reader is enough.
constexpr GIntBig kBlockCacheBytesPerReader = GIntBig(16) << 20;
constexpr GIntBig kMinBlockCacheBytes = GIntBig(32) << 20;
constexpr GIntBig kMaxBlockCacheBytes = GIntBig(256) << 20;

bool blockCacheSetByUser() { return CPLGetConfigOption("GDAL_CACHEMAX", nullptr) != nullptr; }

}  // namespace

void ensureGdalReady() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    CPLSetErrorHandler(routeGdalMessage);
    // GDAL lists a file's folder on every open to find its side files; with
    // thousands of DEM tiles in one folder that is most of the work. Side
    // files (.ovr, .aux.xml, .msk) are then probed one by one instead. A
    // setting in the environment wins.
    if (!CPLGetConfigOption("GDAL_DISABLE_READDIR_ON_OPEN", nullptr)) {
      CPLSetConfigOption("GDAL_DISABLE_READDIR_ON_OPEN", "TRUE");
    }
    // GDAL's block cache grows to 5% of the machine's memory by default,
    // and a deep zoom of a large file reads every block of it once: a
    // 16384² GeoTIFF's zoom 14 peaked at 1.5 GiB, not faster than with a
    // 16 MiB cache (blocks are hardly reused). GDAL_CACHEMAX in the
    // environment wins.
    if (!blockCacheSetByUser()) GDALSetCacheMax64(kMaxBlockCacheBytes);
  });
}

void sizeBlockCacheFor(int readers) {
  ensureGdalReady();
  if (blockCacheSetByUser()) return;
  GDALSetCacheMax64(std::clamp(GIntBig(readers) * kBlockCacheBytesPerReader, kMinBlockCacheBytes, kMaxBlockCacheBytes));
}

std::string lastGdalError() {
  const char* message = CPLGetLastErrorMsg();
  return message && *message ? oneLine(message) : "unknown GDAL error";
}

OGRSpatialReference spatialReference(const std::string& crs) {
  ensureGdalReady();
  OGRSpatialReference srs;
  CPLErrorReset();
  if (srs.SetFromUserInput(crs.c_str()) != OGRERR_NONE) {
    // PROJ's reason, where it gave one: "Cannot find proj.db" says the
    // CRS is fine and PROJ's installation (PROJ_DATA) is not.
    const char* reason = CPLGetLastErrorMsg();
    throw InputError("dem: unknown CRS '" + crs.substr(0, 80) + "'" +
                     (reason && *reason ? " (" + oneLine(reason) + ")" : std::string()));
  }
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);  // x = lon / easting
  return srs;
}

std::string toWkt(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  srs.exportToWkt(&wkt);
  std::string result = wkt ? wkt : "";
  CPLFree(wkt);
  return result;
}

}  // namespace terrabake::dem

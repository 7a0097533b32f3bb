#include "dem/gdal_setup.hpp"

#include <gdal.h>

#include <mutex>

#include "core/log.hpp"

namespace terrabake::dem {
namespace {

void CPL_STDCALL routeGdalMessage(CPLErr level, CPLErrorNum, const char* message) {
  // Failures are reported by the caller with CPLGetLastErrorMsg(); warnings
  // are detail a user asks for with --verbose.
  if (level == CE_Warning) log::debug(std::string("gdal: ") + message);
}

}  // namespace

void ensureGdalReady() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    CPLSetErrorHandler(routeGdalMessage);
  });
}

}  // namespace terrabake::dem

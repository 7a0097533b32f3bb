#pragma once
// Internal to the dem module: which DEM samples are voids, for every way of
// reading a file.
#include <cmath>
#include <optional>

namespace terrabake::dem {

// Heights at or below this are void markers, declared or not: SRTM writes
// -32768 and some products -32767; nothing on Earth lies below -11 km.
inline constexpr double kVoidMarkerMax = -32767.0;

inline bool isVoid(float value, const std::optional<double>& declared_nodata) {
  return !std::isfinite(value) || value <= kVoidMarkerMax || (declared_nodata && value == *declared_nodata);
}

}  // namespace terrabake::dem

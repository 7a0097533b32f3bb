#pragma once
// Internal to the dem module: which DEM samples are voids, for every way of
// reading a file.
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

namespace terrabake::dem {

// Heights at or below this are void markers, declared or not: SRTM writes
// -32768 and some products -32767; nothing on Earth lies below -11 km.
inline constexpr double kVoidMarkerMax = -32767.0;

// What counts as a void in one file: NaN, infinities, the void markers, the
// declared nodata value, and heights beyond the plausible range (1e30 in a
// Float32 file, -3.4e38 undeclared: heights no terrain has, which would
// otherwise tip every normal next to them).
struct VoidRule {
  std::optional<double> nodata;  // as the file declares it
  double min_height = -std::numeric_limits<double>::infinity();  // in the file's units
  double max_height = std::numeric_limits<double>::infinity();
  // Counts the samples read that were voids only for being implausible
  // (infinite or beyond the range); null: not counted.
  std::atomic<long long>* implausible = nullptr;

  bool isVoid(float value) const {
    return !std::isfinite(value) || value <= kVoidMarkerMax || (nodata && value == *nodata) ||
           value < min_height || value > max_height;
  }
  // A void that is neither NaN, a void marker nor the declared nodata value.
  bool isImplausible(float value) const {
    if (std::isnan(value)) return false;
    if (std::isinf(value)) return true;
    if (value <= kVoidMarkerMax || (nodata && value == *nodata)) return false;
    return value < min_height || value > max_height;
  }
  void count(long long samples) const {
    if (implausible && samples > 0) implausible->fetch_add(samples, std::memory_order_relaxed);
  }
};

}  // namespace terrabake::dem

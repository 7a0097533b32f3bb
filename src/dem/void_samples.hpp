#pragma once
// Internal to the dem module: which DEM samples are voids, for every way of
// reading a file.
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

namespace terrabake::dem {

// Samples from -32768 to -32767 are void markers, declared or not: SRTM
// writes -32768 and some products -32767. Samples below are heights beyond
// the plausible range (a void, and a warning that says the file holds them),
// unless the file declares them its nodata value.
inline constexpr double kVoidMarkerMin = -32768.0;
inline constexpr double kVoidMarkerMax = -32767.0;

// The fill value of GIS exports that often goes undeclared: a void where a
// file declares no nodata value, or NaN (one that declares a number is taken
// at its word). A depth of exactly -9999 is a far rarer thing than a missing
// nodata tag.
inline constexpr float kUndeclaredFillValue = -9999.0f;

// A value of a file's band as a read of it into Float32 gives it: the
// nearest float, infinite beyond the float range. A declared nodata value is
// compared as read, so that 0.1 declared by a Float64 file, or 2147483647
// by an Int32 one, matches its samples.
inline float asReadInFloat32(double value) {
  constexpr double kLargest = std::numeric_limits<float>::max();
  if (std::isfinite(value) && std::abs(value) > kLargest) return value > 0 ? INFINITY : -INFINITY;
  return float(value);
}

// How one file's samples become heights, and which are voids: NaN,
// infinities, the void markers, the declared nodata value (all three as
// stored), and heights beyond the plausible range (1e30 in a Float32 file,
// -3.4e38 undeclared: heights no terrain has, which would otherwise tip
// every normal next to them).
struct VoidRule {
  std::optional<float> nodata;   // as a read into Float32 gives it (asReadInFloat32)
  bool fill_value_void = false;  // kUndeclaredFillValue is a void: the file declares no nodata, or NaN
  // The band's scale and offset: a stored sample s is the height
  // s * scale + offset (GDAL's convention; Int16 decimetres have 0.1).
  double scale = 1;
  double offset = 0;
  double min_height = -std::numeric_limits<double>::infinity();  // in the file's height units
  double max_height = std::numeric_limits<double>::infinity();
  // Counts the samples read that were voids only for being implausible
  // (infinite or beyond the range); null: not counted.
  std::atomic<long long>* implausible = nullptr;

  float height(float sample) const { return float(sample * scale + offset); }
  // The rule for samples that are heights already (a file's reduced
  // levels): voids are NaN, heights beyond the range stay voids.
  VoidRule forHeights() const {
    VoidRule heights;
    heights.min_height = min_height;
    heights.max_height = max_height;
    return heights;
  }
  // The tests below are taken each on its own and combined with | and &,
  // not || and &&: with no branch, the loops that classify a window's
  // samples run several at a time.
  bool isVoid(float sample) const {
    const bool not_finite = !std::isfinite(sample), marked = isMarked(sample),
               undeclared_fill = isUndeclaredFill(sample), beyond_range = isBeyondRange(sample);
    return not_finite | marked | undeclared_fill | beyond_range;
  }
  // A void that is neither NaN, a void marker nor the declared nodata value:
  // one the file did not say is one.
  bool isImplausible(float sample) const {
    const bool a_number = !std::isnan(sample), infinite = std::isinf(sample), unmarked = !isMarked(sample),
               undeclared_fill = isUndeclaredFill(sample), beyond_range = isBeyondRange(sample);
    return a_number & unmarked & (infinite | undeclared_fill | beyond_range);
  }
  // A void marker or the declared nodata value (a NaN nodata matches nothing here).
  bool isMarked(float sample) const {
    const bool at_least = sample >= kVoidMarkerMin, at_most = sample <= kVoidMarkerMax;
    const bool marker = at_least & at_most;
    const bool declared = sample == nodata.value_or(NAN);
    return marker | declared;
  }
  bool isUndeclaredFill(float sample) const {
    const bool fill = sample == kUndeclaredFillValue;
    return fill_value_void & fill;
  }
  bool isBeyondRange(float sample) const {
    const double h = sample * scale + offset;
    const bool below = h < min_height, above = h > max_height;
    return below | above;
  }
  void count(long long samples) const {
    if (implausible && samples > 0) implausible->fetch_add(samples, std::memory_order_relaxed);
  }
};

}  // namespace terrabake::dem

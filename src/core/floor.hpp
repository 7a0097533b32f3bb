#pragma once
// floor() and ceil() as integers without a libm call: baseline x86-64 has no
// SSE4.1 rounding instruction, so std::floor is a function call, and the
// kernels turn every texel's position into pixel indices.
namespace terrabake {

// floor(x); values beyond +-2^62 (and NaN, taken as very negative) come back
// as +-2^62, far beyond any raster, where converting would be undefined.
inline long floorToLong(double x) {
  constexpr double kLimit = 4611686018427387904.0;  // 2^62
  if (!(x > -kLimit)) return -(1L << 62);
  if (!(x < kLimit)) return 1L << 62;
  const long truncated = long(x);
  return truncated - (double(truncated) > x ? 1 : 0);
}

// ceil(x), likewise.
inline long ceilToLong(double x) { return -floorToLong(-x); }

}  // namespace terrabake

#pragma once
// floor() and ceil() as integers without a libm call: baseline x86-64 has no SSE4.1
// rounding instruction, so std::floor is a function call, and the kernels
// turn every texel's position into pixel indices.
namespace terrabake {

// floor(x) for finite x within the range of long.
inline long floorToLong(double x) {
  const long truncated = long(x);
  return truncated - (double(truncated) > x ? 1 : 0);
}

// ceil(x), likewise.
inline long ceilToLong(double x) { return -floorToLong(-x); }

}  // namespace terrabake

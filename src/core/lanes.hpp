#pragma once
// Short vectors that add, multiply and compare lane by lane, for the loops
// that take several texels or samples at once (GCC and Clang vector
// extensions: AVX's eight floats where the build targets it, SSE's four
// otherwise, plain scalar code where there is no SIMD). Each lane does
// exactly the arithmetic one value would do alone, so results do not depend
// on the width.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace terrabake {

#if defined(__AVX__)
inline constexpr int kFloatLanes = 8;
#else
inline constexpr int kFloatLanes = 4;
#endif
using Floats = float __attribute__((vector_size(sizeof(float) * kFloatLanes)));
using Ints = std::int32_t __attribute__((vector_size(sizeof(std::int32_t) * kFloatLanes)));

// The kFloatLanes floats from `from` on, aligned or not.
inline Floats loadFloats(const float* from) {
  Floats v;
  std::memcpy(&v, from, sizeof v);
  return v;
}

// 0, 1, 2, ...: each lane's place.
template <class Lanes>
Lanes laneNumbers() {
  Lanes v{};
  for (std::size_t k = 0; k < sizeof v / sizeof v[0]; ++k) v[k] = decltype(+v[0])(k);
  return v;
}

// Each lane's square root, correctly rounded as std::sqrt's.
template <class Lanes>
Lanes squareRoot(Lanes v) {
#if defined(__AVX__)
  if constexpr (sizeof v == 32 && sizeof(v[0]) == sizeof(float)) return Lanes(_mm256_sqrt_ps(__m256(v)));
#endif
#if defined(__SSE2__)
  if constexpr (sizeof v == 16 && sizeof(v[0]) == sizeof(float)) return Lanes(_mm_sqrt_ps(__m128(v)));
#endif
  for (std::size_t k = 0; k < sizeof v / sizeof v[0]; ++k) v[k] = std::sqrt(v[k]);
  return v;
}

}  // namespace terrabake

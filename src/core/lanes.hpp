#pragma once
// Short vectors that add, multiply and compare lane by lane, for the loops
// that take several texels or samples at once (GCC and Clang vector
// extensions: SSE on x86-64, plain scalar code where there is no SIMD).
// Each lane does exactly the arithmetic one value would do alone.
#include <cmath>
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace terrabake {

inline constexpr int kFloatLanes = 4;
using Floats = float __attribute__((vector_size(16)));
using Ints = std::int32_t __attribute__((vector_size(16)));
using Doubles = double __attribute__((vector_size(16)));

// Each lane's square root, correctly rounded as std::sqrt's.
template <class Lanes>
Lanes squareRoot(Lanes v) {
#if defined(__SSE2__)
  if constexpr (sizeof(v[0]) == sizeof(float)) {
    return Lanes(_mm_sqrt_ps(__m128(v)));
  } else {
    return Lanes(_mm_sqrt_pd(__m128d(v)));
  }
#else
  for (std::size_t k = 0; k < sizeof v / sizeof v[0]; ++k) v[k] = std::sqrt(v[k]);
  return v;
#endif
}

}  // namespace terrabake

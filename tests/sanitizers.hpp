#pragma once
// Whether the tests are built with the sanitizers (the asan presets), for the
// few claims about time that their slowdown changes.

namespace terrabake::test {

// Whether these tests and terrabake are built with AddressSanitizer.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

// How much longer terrabake takes under the sanitizers than in a plain build
// (the asan preset measured up to 9x on opening a world DEM): time bounds
// stated for the plain build are multiplied by it.
inline constexpr double kSanitizerSlowdown = kAddressSanitizer ? 10.0 : 1.0;

}  // namespace terrabake::test

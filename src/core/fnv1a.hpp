#pragma once
// The 64-bit FNV-1a hash of bytes: a fast, stable fingerprint (not a
// cryptographic one), the same on every machine. Pass the previous hash as
// `hash` to go on over more bytes.
#include <cstddef>
#include <cstdint>

namespace terrabake {

inline constexpr std::uint64_t kFnv1aOffset = 14695981039346656037ULL;

inline std::uint64_t fnv1a(const void* data, std::size_t size, std::uint64_t hash = kFnv1aOffset) {
  constexpr std::uint64_t kPrime = 1099511628211ULL;
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t k = 0; k < size; ++k) hash = (hash ^ bytes[k]) * kPrime;
  return hash;
}

}  // namespace terrabake

#pragma once
// The one rule for layer names: a layer is a folder (or <name>.mbtiles, or
// <name>.pmtiles) and a URL segment, so its name has no separators and
// nothing that climbs out.
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <string_view>

namespace terrabake {

// File systems take names of up to 255 bytes; the layer's hidden temporary
// files and companion archives add up to about 60 to its name.
inline constexpr std::size_t kMaxLayerNameBytes = 128;

inline bool isLayerName(std::string_view name) {
  const bool safe_chars = std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
  });
  return !name.empty() && name.size() <= kMaxLayerNameBytes && safe_chars && name != "." && name != "..";
}

}  // namespace terrabake

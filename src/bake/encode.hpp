#pragma once
// Normal map to integer RGB, exactly as docs/CONTRACT.md §3 states.
#include <cstdint>

#include "bake/baker.hpp"
#include "core/choices.hpp"
#include "core/types.hpp"

namespace terrabake::bake {

// rgb = round((n * 0.5 + 0.5) * (2^bits - 1)); bits is 8 or 16. Values are
// stored in uint16_t whatever the depth.
Image<std::uint16_t> encodeNormalMap(const NormalMap& map, int bits, Green green);

// RGB to RGBA: alpha 2^bits - 1 where `covered` is non-zero, 0 elsewhere.
// `covered` has the image's size, row 0 at the top.
Image<std::uint16_t> addAlpha(const Image<std::uint16_t>& rgb, const Raster<std::uint8_t>& covered, int bits);

}  // namespace terrabake::bake

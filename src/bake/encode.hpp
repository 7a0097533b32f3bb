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

// Heights to an 8-bit RGB elevation tile for MapLibre's raster-dem
// (docs/CONTRACT.md §3): pixel (i, j) holds heights(apron + i, apron + j),
// metres, encoded as `encoding` says and rounded to the nearest step (1/256 m
// for Terrarium, 0.1 m for Terrain-RGB). Heights beyond what the encoding
// holds are clamped to its ends and counted.
struct ElevationImage {
  Image<std::uint16_t> image;  // 8-bit values
  std::size_t clamped = 0;     // pixels clamped to the encoding's range
};
ElevationImage encodeElevation(const Raster<float>& heights, int apron, int size, Elevation encoding);

}  // namespace terrabake::bake

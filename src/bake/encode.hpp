#pragma once
// Normal map to integer RGB, exactly as CONTRACT section 3 states.
#include <cstdint>

#include "bake/baker.hpp"
#include "core/types.hpp"

namespace terrabake::bake {

enum class Green { kUp, kDown };  // +Y of tangent space north (OpenGL) or south (DirectX)

// rgb = round((n * 0.5 + 0.5) * (2^bits - 1)); bits is 8 or 16. Values are
// stored in uint16_t whatever the depth.
Image<std::uint16_t> encodeNormalMap(const NormalMap& map, int bits, Green green);

}  // namespace terrabake::bake

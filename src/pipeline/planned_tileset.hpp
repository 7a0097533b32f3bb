#pragma once
// A layer's 3D Tiles tileset (io/tileset.hpp) before its tiles exist, for
// layers baked on demand: each tile's placement comes from the plan instead
// of its .glb. The transform is the frame the tile maker will use; the
// region is the tile's extent and the heights its meshes and skirts can
// reach (HeightBounds, docs/CONTRACT.md §8); the error is the zoom's bound.
#include <cstdint>
#include <vector>

#include "io/tileset.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

// The most tiles a planned tileset holds. The documents are kept in memory
// whole, about 0.9 KB a tile, so this bounds them to some 45 MB; a larger
// layer gets its tileset from `terrabake tile` with output.tileset.
inline constexpr std::uint64_t kMaxPlannedTilesetTiles = 50000;

// The tileset over the plan's tiles that hold a DEM sample (as far as a
// coarse read of the DEM tells: a tile it cannot rule out is listed).
// Reads the DEM once. Throws InputError when the plan holds more than
// kMaxPlannedTilesetTiles tiles or no tile with a sample.
std::vector<io::TilesetDocument> planTileset(const LayerPlan& plan);

}  // namespace terrabake::pipeline

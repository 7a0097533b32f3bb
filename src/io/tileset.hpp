#pragma once
// A layer as OGC 3D Tiles 1.1 (docs/CONTRACT.md §8): tileset.json over the
// .glb meshes the layer already holds, so CesiumJS, 3d-tiles-renderer and
// other 3D Tiles viewers stream it with its normal maps.
#include <array>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"

namespace terrabake::io {

// The main tileset beside tilejson.json; deeper levels are external tilesets.
inline constexpr const char* kTilesetFile = "tileset.json";
// Levels of the pyramid in one tileset file: a file holds at most
// (4^6 - 1) / 3 = 1365 tiles, and the tiles that start the next six levels
// point to their own file.
inline constexpr int kTilesetLevelsPerFile = 6;

// One mesh of the layer and where it lies (GlbPlacement).
struct TilesetTile {
  TileId tile;
  GlbPlacement placement;
};

// A JSON file of the tileset, at `path` relative to the layer folder.
struct TilesetDocument {
  std::string path;
  std::string json;
};

// "tilesets/z/x/y.json": the external tileset whose root is `tile`.
std::string externalTilesetPath(const TileId& tile);

// The tileset over `tiles` (any order; tile (z, x, y)'s parent is
// (z - 1, x / 2, y / 2) in every scheme): tileset.json first, then the
// external tilesets. A synthetic root without content holds the tiles of
// the shallowest zoom (and any tile whose parent is missing). Each tile's
// region holds its own and all its descendants'; its geometricError is 0 at
// the leaves, else the larger of its mesh's max_error_m and its texel's
// ground size, and always above its children's; refine is REPLACE; its
// transform composed down the tree gives its mesh's enu_to_ecef (after
// glTF's y-up to 3D Tiles' z-up turn). `tile_size` gives the texel size.
// Throws std::invalid_argument when `tiles` is empty or holds a tile twice.
std::vector<TilesetDocument> buildTileset(const std::vector<TilesetTile>& tiles, int tile_size);

}  // namespace terrabake::io

#include "tiling/scheme.hpp"

#include <algorithm>
#include <cmath>

namespace terrabake::tiling {

Extent Scheme::tileExtent(const TileId& tile) const {
  const LevelGrid g = levelGrid(tile.z);
  const int row_from_north = tmsRows() ? g.rows - 1 - tile.y : tile.y;
  // Edges come from integer tile counts, so neighbours share them exactly.
  return {g.west + tile.x * g.tile_w, g.north - (row_from_north + 1) * g.tile_h,
          g.west + (tile.x + 1) * g.tile_w, g.north - row_from_north * g.tile_h};
}

std::vector<TileId> Scheme::tilesCovering(const Extent& area, int zoom) const {
  const LevelGrid g = levelGrid(zoom);
  const int x0 = std::clamp(int(std::floor((area.min_x - g.west) / g.tile_w)), 0, g.cols - 1);
  const int x1 = std::clamp(int(std::ceil((area.max_x - g.west) / g.tile_w)) - 1, 0, g.cols - 1);
  const int r0 = std::clamp(int(std::floor((g.north - area.max_y) / g.tile_h)), 0, g.rows - 1);
  const int r1 = std::clamp(int(std::ceil((g.north - area.min_y) / g.tile_h)) - 1, 0, g.rows - 1);
  std::vector<TileId> tiles;
  for (int r = r0; r <= r1; ++r) {
    for (int x = x0; x <= x1; ++x) tiles.push_back({zoom, x, tmsRows() ? g.rows - 1 - r : r});
  }
  return tiles;
}

GridSpec Scheme::texelGrid(const TileId& tile, int tile_size, int apron) const {
  const Extent e = tileExtent(tile);
  GridSpec grid;
  grid.crs = crs();
  grid.cell_w = e.width() / tile_size;
  grid.cell_h = e.height() / tile_size;
  grid.origin_x = e.min_x - apron * grid.cell_w;
  grid.origin_y = e.max_y + apron * grid.cell_h;
  grid.width = grid.height = tile_size + 2 * apron;
  return grid;
}

std::string tilePath(const std::string& layer_dir, const TileId& tile, const std::string& extension) {
  return layer_dir + "/" + std::to_string(tile.z) + "/" + std::to_string(tile.x) + "/" +
         std::to_string(tile.y) + "." + extension;
}

}  // namespace terrabake::tiling

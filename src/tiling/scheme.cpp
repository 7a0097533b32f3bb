#include "tiling/scheme.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace terrabake::tiling {

std::unique_ptr<Scheme> makeWebMercator(int tile_size);
std::unique_ptr<Scheme> makeGeodetic(int tile_size);
std::unique_ptr<Scheme> makeNative(const GridSpec& dem_grid, int tile_size);

std::unique_ptr<Scheme> makeScheme(SchemeKind kind, int tile_size, const GridSpec* dem_grid) {
  switch (kind) {
    case SchemeKind::kWebMercator:
      return makeWebMercator(tile_size);
    case SchemeKind::kGeodetic:
      return makeGeodetic(tile_size);
    case SchemeKind::kNative:
      if (!dem_grid) throw std::invalid_argument("makeScheme: the native scheme needs the DEM's grid");
      return makeNative(*dem_grid, tile_size);
  }
  throw std::invalid_argument("makeScheme: unknown scheme");
}

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

bool Scheme::covers(const Extent& area, const TileId& tile) const {
  if (tile.z < 0 || tile.z > maxZoom()) return false;
  const LevelGrid grid = levelGrid(tile.z);
  if (tile.x < 0 || tile.y < 0 || tile.x >= grid.cols || tile.y >= grid.rows) return false;
  const Extent extent = tileExtent(tile);
  if (!extent.intersects(area)) return false;
  // tilesCovering over the overlap alone: the same rule for edge cases, at
  // the cost of a handful of tiles instead of a whole zoom.
  const Extent overlap{std::max(extent.min_x, area.min_x), std::max(extent.min_y, area.min_y),
                       std::min(extent.max_x, area.max_x), std::min(extent.max_y, area.max_y)};
  const std::vector<TileId> tiles = tilesCovering(overlap, tile.z);
  return std::find(tiles.begin(), tiles.end(), tile) != tiles.end();
}

GridSpec Scheme::texelGrid(const TileId& tile, int apron) const {
  const Extent e = tileExtent(tile);
  GridSpec grid;
  grid.crs = crs();
  grid.cell_w = e.width() / m_tile_size;
  grid.cell_h = e.height() / m_tile_size;
  grid.origin_x = e.min_x - apron * grid.cell_w;
  grid.origin_y = e.max_y + apron * grid.cell_h;
  grid.width = grid.height = m_tile_size + 2 * apron;
  return grid;
}

}  // namespace terrabake::tiling

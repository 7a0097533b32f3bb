#include "tiling/scheme.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/extent_groups.hpp"

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

std::optional<Extent> Scheme::globe() const {
  if (kind() == SchemeKind::kNative) return std::nullopt;
  const LevelGrid g = levelGrid(0);
  return Extent{g.west, g.north - g.rows * g.tile_h, g.west + g.cols * g.tile_w, g.north};
}

Extent Scheme::tileExtent(const TileId& tile) const {
  const LevelGrid g = levelGrid(tile.z);
  const int row_from_north = tmsRows() ? g.rows - 1 - tile.y : tile.y;
  // Edges come from integer tile counts, so neighbours share them exactly.
  return {g.west + tile.x * g.tile_w, g.north - (row_from_north + 1) * g.tile_h,
          g.west + (tile.x + 1) * g.tile_w, g.north - row_from_north * g.tile_h};
}

TileRange Scheme::rangeCovering(const Extent& area, int zoom) const {
  const LevelGrid g = levelGrid(zoom);
  // Clamped in floating point first, so an area far beyond the grid cannot overflow an int.
  const auto index = [](double v, int high) { return int(std::clamp(v, 0.0, double(high))); };
  TileRange range;
  range.zoom = zoom;
  range.x0 = index(std::floor((area.min_x - g.west) / g.tile_w), g.cols - 1);
  range.x1 = index(std::ceil((area.max_x - g.west) / g.tile_w) - 1, g.cols - 1);
  range.r0 = index(std::floor((g.north - area.max_y) / g.tile_h), g.rows - 1);
  range.r1 = index(std::ceil((g.north - area.min_y) / g.tile_h) - 1, g.rows - 1);
  return range;
}

std::vector<TileRange> Scheme::rangesCovering(const std::vector<Extent>& areas, int zoom) const {
  // As boxes of tile indices that meet where ranges share a tile, with y
  // the negated row so that north-first is mergeMeeting's order.
  std::vector<Extent> boxes;
  for (const Extent& area : areas) {
    const TileRange range = rangeCovering(area, zoom);
    if (range.count() > 0) boxes.push_back({double(range.x0), -double(range.r1), double(range.x1), -double(range.r0)});
  }
  std::vector<TileRange> ranges;
  for (const Extent& box : mergeMeeting(boxes)) {
    ranges.push_back({zoom, int(box.min_x), int(box.max_x), int(-box.max_y), int(-box.min_y)});
  }
  return ranges;
}

TileId Scheme::tileAt(const TileRange& range, std::uint64_t index) const {
  const std::uint64_t cols = std::uint64_t(range.x1 - range.x0 + 1);
  const int r = range.r0 + int(index / cols);
  const int x = range.x0 + int(index % cols);
  return {range.zoom, x, tmsRows() ? levelGrid(range.zoom).rows - 1 - r : r};
}

std::vector<TileId> Scheme::tilesCovering(const Extent& area, int zoom) const {
  const TileRange range = rangeCovering(area, zoom);
  std::vector<TileId> tiles;
  tiles.reserve(std::size_t(range.count()));
  for (std::uint64_t i = 0; i < range.count(); ++i) tiles.push_back(tileAt(range, i));
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
  const std::vector<TileId> tiles = tilesCovering(extent.intersection(area), tile.z);
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

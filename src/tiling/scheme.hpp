#pragma once
// Tiling schemes (docs/CONTRACT.md §2): which tiles exist at a zoom, where
// each lies in the scheme's CRS, and the texel grid of a tile. A scheme owns
// its tile size and, for the global schemes, its lon/lat <-> CRS mapping.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/choices.hpp"
#include "core/types.hpp"

namespace terrabake::tiling {

// The tiles of one zoom that overlap an area, without listing them: columns
// x0..x1 and rows r0..r1 counted from the north, in row-major order from the
// north-west. Empty when x1 < x0.
struct TileRange {
  int zoom = 0;
  int x0 = 0, x1 = -1;
  int r0 = 0, r1 = -1;
  std::uint64_t count() const {
    return x1 < x0 || r1 < r0 ? 0 : std::uint64_t(x1 - x0 + 1) * std::uint64_t(r1 - r0 + 1);
  }
};

// The tiles of one zoom level: a regular grid in the scheme's CRS.
struct LevelGrid {
  double west = 0;
  double north = 0;
  double tile_w = 0;  // CRS units
  double tile_h = 0;
  int cols = 0;
  int rows = 0;
};

class Scheme {
 public:
  explicit Scheme(int tile_size) : m_tile_size(tile_size) {}
  virtual ~Scheme() = default;

  virtual SchemeKind kind() const = 0;
  std::string name() const { return std::string(wordOf(kind())); }
  // The CRS tile extents are expressed in (WKT or "EPSG:n").
  virtual std::string crs() const = 0;
  // True when row y = 0 is the south edge (TMS), false for north (XYZ).
  virtual bool tmsRows() const = 0;
  virtual int maxZoom() const = 0;
  virtual LevelGrid levelGrid(int zoom) const = 0;
  // Texels a side of every tile.
  int tileSize() const { return m_tile_size; }

  // The latitude, north and south, up to which the scheme reaches (Web
  // Mercator stops short of the poles).
  virtual double maxLatDeg() const { return 90; }
  // A lon/lat box in the scheme's CRS; nullopt for a scheme whose CRS only
  // the DEM's georeferencing can map (native).
  virtual std::optional<Extent> fromLonLat(const Extent& lon_lat) const = 0;

  // The whole globe in the scheme's CRS, the extent of its zoom 0, whose
  // east edge is its west edge a turn round (the antimeridian); nullopt for
  // native, whose tiles end where the DEM does.
  std::optional<Extent> globe() const;

  Extent tileExtent(const TileId& tile) const;
  // Tiles at `zoom` whose extent overlaps `area` (in the scheme's CRS), in
  // row-major order from the north-west.
  std::vector<TileId> tilesCovering(const Extent& area, int zoom) const;
  // The same tiles as a range: counted and indexed without listing them.
  TileRange rangeCovering(const Extent& area, int zoom) const;
  // The tiles at `zoom` that overlap any of `areas`, each once: ranges that
  // share no tile, north to south, each holding the tiles of one or more
  // areas' ranges (and those between them). Empty ranges are left out.
  std::vector<TileRange> rangesCovering(const std::vector<Extent>& areas, int zoom) const;
  // Tile `index` (< range.count()) of the range, in tilesCovering's order.
  TileId tileAt(const TileRange& range, std::uint64_t index) const;
  // Whether `tile` is one of tilesCovering(area, tile.z), without listing the zoom.
  bool covers(const Extent& area, const TileId& tile) const;

  // The texel grid of a tile, run on `apron` texels beyond each edge: cell
  // (apron + i, apron + j) is texel (i, j).
  GridSpec texelGrid(const TileId& tile, int apron) const;

 private:
  int m_tile_size;
};

// The one factory: webmercator is EPSG:3857 with one tile at zoom 0 and y = 0
// at the north edge (XYZ); geodetic is EPSG:4326 with two tiles at zoom 0
// (west, east) and y = 0 at the south edge (TMS); native is the DEM's own CRS
// and pixel grid, level `levels - 1` at full resolution and level 0 one tile
// over the whole DEM. Native needs `dem_grid`; throws std::invalid_argument
// without it.
std::unique_ptr<Scheme> makeScheme(SchemeKind kind, int tile_size, const GridSpec* dem_grid = nullptr);

}  // namespace terrabake::tiling

#pragma once
// Tiling schemes (docs/CONTRACT.md §2): which tiles exist at a zoom, where
// each lies in the scheme's CRS, and where its files go.
#include <memory>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace terrabake::tiling {

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
  virtual ~Scheme() = default;
  virtual std::string name() const = 0;
  // The CRS tile extents are expressed in (WKT or "EPSG:n").
  virtual std::string crs() const = 0;
  // True when row y = 0 is the south edge (TMS), false for north (XYZ).
  virtual bool tmsRows() const = 0;
  virtual int maxZoom() const = 0;
  virtual LevelGrid levelGrid(int zoom) const = 0;

  Extent tileExtent(const TileId& tile) const;
  // Tiles at `zoom` whose extent overlaps `area` (in the scheme's CRS), in
  // row-major order from the north-west.
  std::vector<TileId> tilesCovering(const Extent& area, int zoom) const;

  // The texel grid of a tile of `tile_size` texels a side, run on `apron`
  // texels beyond each edge: cell (apron + i, apron + j) is texel (i, j).
  GridSpec texelGrid(const TileId& tile, int tile_size, int apron) const;
};

// EPSG:3857, one tile at zoom 0, y = 0 at the north edge (XYZ).
std::unique_ptr<Scheme> makeWebMercator();

// EPSG:4326, two tiles at zoom 0 (west, east), y = 0 at the south edge (TMS).
std::unique_ptr<Scheme> makeGeodetic();

// The DEM's own CRS and pixel grid: level `levels - 1` is full resolution,
// level 0 one tile over the whole DEM, each tile starting at the north-west.
std::unique_ptr<Scheme> makeNative(const GridSpec& dem_grid, int tile_size);

// "{root}/{layer}/{z}/{x}/{y}.{extension}"
std::string tilePath(const std::string& layer_dir, const TileId& tile, const std::string& extension);

}  // namespace terrabake::tiling

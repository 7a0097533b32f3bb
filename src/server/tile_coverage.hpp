#pragma once
// Which tiles a layer has: its zoom range and, where the tiling scheme is
// known, the area its tiles cover, exactly as a batch run chooses them.
#include <memory>
#include <vector>

#include "core/types.hpp"
#include "io/tile_files.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::server {

class TileCoverage {
 public:
  // Zooms only: for layers whose grid the server cannot rebuild (a native
  // layer without its DEM); the files on disk decide the rest.
  TileCoverage(int min_zoom, int max_zoom);

  // The tiles of `scheme` that tilesCovering(area, z) gives for one of
  // `areas` (two for a layer across the antimeridian), z in the range.
  TileCoverage(int min_zoom, int max_zoom, std::shared_ptr<const tiling::Scheme> scheme, std::vector<Extent> areas);

  bool contains(const TileId& tile) const;

 private:
  int m_min_zoom;
  int m_max_zoom;
  std::shared_ptr<const tiling::Scheme> m_scheme;  // null: zooms only
  std::vector<Extent> m_areas;                     // in the scheme's CRS
};

// What a layer's tilejson says it covers: for webmercator and geodetic
// layers its bounds in the scheme's grid (west above east: across the
// antimeridian, one area each side); for others (native: the grid comes
// from the DEM) its zooms only.
TileCoverage coverageOf(const io::TileJsonSummary& tilejson);

}  // namespace terrabake::server

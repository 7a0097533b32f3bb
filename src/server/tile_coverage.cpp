#include "server/tile_coverage.hpp"

#include <algorithm>

namespace terrabake::server {

TileCoverage::TileCoverage(int min_zoom, int max_zoom) : m_min_zoom(min_zoom), m_max_zoom(max_zoom) {}

TileCoverage::TileCoverage(int min_zoom, int max_zoom, std::shared_ptr<const tiling::Scheme> scheme,
                           std::vector<Extent> areas)
    : m_min_zoom(min_zoom), m_max_zoom(max_zoom), m_scheme(std::move(scheme)), m_areas(std::move(areas)) {}

bool TileCoverage::contains(const TileId& tile) const {
  if (tile.z < m_min_zoom || tile.z > m_max_zoom) return false;
  return !m_scheme || std::any_of(m_areas.begin(), m_areas.end(),
                                  [&](const Extent& area) { return m_scheme->covers(area, tile); });
}

TileCoverage coverageOf(const io::TileJsonSummary& tilejson) {
  // A native grid comes from the DEM, and an unknown scheme from nowhere:
  // the zooms are all the tilejson can say.
  if (!tilejson.scheme || *tilejson.scheme == SchemeKind::kNative) {
    return TileCoverage(tilejson.min_zoom, tilejson.max_zoom);
  }
  // Which tiles a global scheme has does not depend on the tile size.
  std::shared_ptr<const tiling::Scheme> scheme = tiling::makeScheme(*tilejson.scheme, tilejson.tile_size);
  const auto [west, south, east, north] = tilejson.bounds_deg;
  const std::vector<Extent> lon_lat =
      west <= east ? std::vector<Extent>{{west, south, east, north}}
                   : std::vector<Extent>{{west, south, 180, north}, {-180, south, east, north}};
  std::vector<Extent> areas;
  for (const Extent& piece : lon_lat) {
    const std::optional<Extent> area = scheme->fromLonLat(piece);
    if (!area) return TileCoverage(tilejson.min_zoom, tilejson.max_zoom);
    areas.push_back(*area);
  }
  return TileCoverage(tilejson.min_zoom, tilejson.max_zoom, std::move(scheme), std::move(areas));
}

}  // namespace terrabake::server

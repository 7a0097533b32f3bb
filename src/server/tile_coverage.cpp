#include "server/tile_coverage.hpp"

#include <algorithm>
#include <cmath>

namespace terrabake::server {
namespace {

constexpr double kEarthRadiusM = 6378137.0;  // the sphere of EPSG:3857
constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

TileCoverage::TileCoverage(int min_zoom, int max_zoom) : m_min_zoom(min_zoom), m_max_zoom(max_zoom) {}

TileCoverage::TileCoverage(int min_zoom, int max_zoom, std::shared_ptr<const tiling::Scheme> scheme,
                           const Extent& area)
    : m_min_zoom(min_zoom), m_max_zoom(max_zoom), m_scheme(std::move(scheme)), m_area(area) {}

bool TileCoverage::contains(const TileId& tile) const {
  if (tile.z < m_min_zoom || tile.z > m_max_zoom) return false;
  if (!m_scheme) return true;
  if (tile.z > m_scheme->maxZoom()) return false;
  const tiling::LevelGrid grid = m_scheme->levelGrid(tile.z);
  if (tile.x < 0 || tile.y < 0 || tile.x >= grid.cols || tile.y >= grid.rows) return false;
  const Extent extent = m_scheme->tileExtent(tile);
  if (!extent.intersects(m_area)) return false;
  // tilesCovering over the overlap alone: the batch run's own rule for
  // edge cases, at the cost of a handful of tiles instead of a whole zoom.
  const Extent overlap{std::max(extent.min_x, m_area.min_x), std::max(extent.min_y, m_area.min_y),
                       std::min(extent.max_x, m_area.max_x), std::min(extent.max_y, m_area.max_y)};
  const std::vector<TileId> tiles = m_scheme->tilesCovering(overlap, tile.z);
  return std::find(tiles.begin(), tiles.end(), tile) != tiles.end();
}

TileCoverage coverageOf(const TileJsonSummary& tilejson) {
  const auto [west, south, east, north] = tilejson.bounds_deg;
  if (tilejson.scheme == "geodetic") {
    return TileCoverage(tilejson.min_zoom, tilejson.max_zoom, tiling::makeGeodetic(),
                        Extent{west, south, east, north});
  }
  if (tilejson.scheme == "webmercator") {
    // Spherical Mercator keeps east-west and north-south apart, so the box maps to a box.
    const auto x = [](double lon_deg) { return kEarthRadiusM * lon_deg * kDegToRad; };
    const auto y = [](double lat_deg) {
      return kEarthRadiusM * std::log(std::tan(M_PI / 4 + lat_deg * kDegToRad / 2));
    };
    return TileCoverage(tilejson.min_zoom, tilejson.max_zoom, tiling::makeWebMercator(),
                        Extent{x(west), y(south), x(east), y(north)});
  }
  return TileCoverage(tilejson.min_zoom, tilejson.max_zoom);
}

}  // namespace terrabake::server

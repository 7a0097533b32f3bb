#include "pipeline/zoom_choice.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "core/extent_groups.hpp"
#include "dem/crs_transform.hpp"
#include "geo/local_frame.hpp"

namespace terrabake::pipeline {
namespace {

// A texel computed equal to a pixel (native grids, round numbers) must not
// lose to float noise.
constexpr double kSizeTolerance = 1e-9;

}  // namespace

std::vector<Extent> lonLatPieces(const Extent& box, double max_lat_deg) {
  Extent e = box;
  e.min_y = std::max(e.min_y, -max_lat_deg);
  e.max_y = std::min(e.max_y, max_lat_deg);
  if (e.min_y >= e.max_y) return {};
  if (e.min_x > e.max_x) e.max_x += 360;  // across the antimeridian
  // The whole globe, however it is registered: a grid of pixel centres from
  // -180 to 180 reaches half a pixel beyond each.
  if (e.max_x - e.min_x >= 360) return {{-180, e.min_y, 180, e.max_y}};
  e = dem::turnedIntoRange(e);  // longitudes counted 0 to 360 are the same places
  if (e.max_x <= 180) return {e};
  return {{e.min_x, e.min_y, 180, e.max_y}, {-180, e.min_y, e.max_x - 360, e.max_y}};
}

namespace {

// demAreas of a part of the DEM (all of it, or one file), given its bounds in a CRS.
std::vector<Extent> areasOf(const tiling::Scheme& scheme, const std::function<Extent(const std::string&)>& bounds_in) {
  const std::vector<Extent> lon_lat_pieces = lonLatPieces(bounds_in("EPSG:4326"), scheme.maxLatDeg());
  if (lon_lat_pieces.empty()) return {};
  std::vector<Extent> pieces;
  for (const Extent& piece : lon_lat_pieces) {
    if (const auto area = scheme.fromLonLat(piece)) pieces.push_back(*area);
  }
  // Across the antimeridian or round the whole globe, the pieces are the
  // areas: the DEM's own extent would run past 180.
  const bool whole_globe = lon_lat_pieces.front().max_x - lon_lat_pieces.front().min_x >= 360;
  if (pieces.size() > 1 || (whole_globe && !pieces.empty())) return pieces;
  // One piece: the DEM's extent transformed straight into the scheme's CRS
  // (the native scheme's grid is the DEM's own, counted as the DEM counts).
  Extent area = bounds_in(scheme.crs());
  if (scheme.kind() == SchemeKind::kNative) return {area};
  if (const std::optional<Extent> globe = scheme.globe()) {
    area = dem::turnedIntoRange(area, globe->min_x, globe->width());  // counted past the globe's east edge
  }
  // Within the scheme's latitudes: a DEM reaching nearer a pole than Web
  // Mercator's 85.05 degrees runs far past its map (to infinity at the
  // pole), which would put the area's centre, where auto's zoom and the
  // error bounds are judged, off the map.
  const double max_lat = scheme.maxLatDeg();
  if (const auto map = scheme.fromLonLat({-180, -max_lat, 180, max_lat})) {
    area.min_y = std::max(area.min_y, map->min_y);
    area.max_y = std::min(area.max_y, map->max_y);
  }
  return {area};
}

}  // namespace

std::vector<Extent> demAreas(const tiling::Scheme& scheme, const dem::DemSource& dem) {
  return areasOf(scheme, [&](const std::string& crs) { return dem.boundsIn(crs); });
}

std::vector<FileGroup> fileGroups(const tiling::Scheme& scheme, const dem::DemSource& dem) {
  std::vector<Extent> areas;
  std::vector<std::optional<Extent>> judging_area(dem.fileCount());  // each file's first
  for (std::size_t file = 0; file < dem.fileCount(); ++file) {
    for (std::size_t part = 0; part < dem.filePartCount(file); ++part) {
      const auto bounds_in = [&](const std::string& crs) { return dem.filePartBoundsIn(file, part, crs); };
      for (const Extent& area : areasOf(scheme, bounds_in)) {
        if (!judging_area[file]) judging_area[file] = area;
        areas.push_back(area);
      }
    }
  }
  const std::vector<Extent> merged = mergeMeeting(areas);
  std::vector<FileGroup> groups;
  for (const Extent& area : merged) groups.push_back({area, {}});
  for (std::size_t file = 0; file < dem.fileCount(); ++file) {
    if (judging_area[file]) {  // else beyond the scheme's latitudes
      groups[holderOf(merged, *judging_area[file])].files.push_back(file);
    }
  }
  return groups;
}

std::vector<Extent> groupAreas(const std::vector<FileGroup>& groups) {
  std::vector<Extent> areas;
  for (const FileGroup& group : groups) areas.push_back(group.area);
  return areas;
}

std::size_t groupJudging(const std::vector<FileGroup>& groups, std::size_t file) {
  std::optional<std::size_t> first;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const std::vector<std::size_t>& files = groups[g].files;
    if (std::find(files.begin(), files.end(), file) != files.end()) return g;
    if (!first && !files.empty()) first = g;
  }
  return first.value_or(0);
}

double cellGroundSizeM(const std::string& crs, double x, double y, double cell_w, double cell_h) {
  std::vector<glm::dvec2> ends = {
      {x - cell_w / 2, y}, {x + cell_w / 2, y}, {x, y - cell_h / 2}, {x, y + cell_h / 2}};
  dem::ToLonLat(crs).transform(ends,
                               "the cell whose ground size sets the zooms lies outside the CRS's domain (check the "
                               "DEM's geotransform and CRS)");
  std::vector<glm::dvec3> ecef;
  for (const glm::dvec2& p : ends) ecef.push_back(geo::geodeticToEcef(p.x, p.y, 0));
  return std::sqrt(glm::distance(ecef[0], ecef[1]) * glm::distance(ecef[2], ecef[3]));
}

namespace {

double pixelSizeAtCentreM(const GridSpec& g) {
  return cellGroundSizeM(g.crs, g.centreX(g.width / 2.0 - 0.5), g.centreY(g.height / 2.0 - 0.5), g.cell_w,
                         g.cell_h);
}

}  // namespace

double demPixelSizeM(const dem::DemSource& dem) { return pixelSizeAtCentreM(dem.info().grid); }

double pixelSizeM(const dem::DemSource& dem, const std::vector<std::size_t>& files) {
  return pixelSizeAtCentreM(dem.gridOf(files));
}

int autoMaxZoom(const tiling::Scheme& scheme, const std::vector<FileGroup>& groups, const dem::DemSource& dem) {
  int zoom = 0;
  for (const FileGroup& group : groups) {
    if (!group.files.empty()) zoom = std::max(zoom, autoMaxZoom(scheme, group.area, pixelSizeM(dem, group.files)));
  }
  return zoom;
}

int autoMaxZoom(const tiling::Scheme& scheme, const Extent& area, double pixel_m) {
  if (scheme.kind() == SchemeKind::kNative) return scheme.maxZoom();
  const int tile_size = scheme.tileSize();
  const double x = (area.min_x + area.max_x) / 2, y = (area.min_y + area.max_y) / 2;
  int zoom = 0;
  for (int z = 1; z <= scheme.maxZoom(); ++z) {
    const tiling::LevelGrid level = scheme.levelGrid(z);
    const double texel_m =
        cellGroundSizeM(scheme.crs(), x, y, level.tile_w / tile_size, level.tile_h / tile_size);
    if (texel_m < pixel_m * (1 - kSizeTolerance)) break;
    zoom = z;
  }
  return zoom;
}

int oneTileZoom(const tiling::Scheme& scheme, const Extent& area, int max_zoom) {
  int zoom = 0;
  for (int z = 0; z <= max_zoom && scheme.rangeCovering(area, z).count() == 1; ++z) zoom = z;
  return zoom;
}

}  // namespace terrabake::pipeline

#include "pipeline/planned_tileset.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>

#include "core/error.hpp"
#include "dem/crs_transform.hpp"
#include "dem/fill_holes.hpp"
#include "geo/region.hpp"
#include "pipeline/height_bounds.hpp"
#include "pipeline/tile_frame.hpp"

namespace terrabake::pipeline {
namespace {

constexpr double kHalfPi = 1.57079632679489661923;
// How far the surface carried into a hole (dem/fill_holes.hpp) rises or
// falls beyond the edge sample it starts from, in texel steps times its
// reach: the edge's slope carried on, faded out by a smoothstep, goes
// furthest, 0.26 reach steps, at 0.42 of the reach; rounded up.
constexpr double kFillOvershootShare = 0.3;
// Points along each tile edge taken to longitude and latitude: a native
// CRS's edges curve there, between the points by far less than a texel.
constexpr int kEdgePoints = 16;
// A texel holds a sample only where half of it lies on data, so a tile
// whose overlap with every file's area is under half a texel across holds
// none, and a batch run writes no file of it. Half of that half is asked
// for: the areas are boxes round the files' edges densified into the
// scheme's CRS, whose curves between the points may bulge past them.
constexpr double kTexelShareOnData = 0.25;

struct LonLatBox {
  double west = 0, south = 0, east = 0, north = 0;  // radians; west > east across the antimeridian
};

// The extent in longitude and latitude: its edges walked round in order,
// each point's longitude taken the shorter way from the one before, so that
// an extent across the antimeridian, or counted past it, stays one span
// (west > east where it runs across), and one whose edges wind round the
// earth's axis (a polar CRS's tile round a pole) spans every longitude and
// reaches the pole.
LonLatBox lonLatOf(const Extent& e, const dem::ToLonLat& to_lon_lat) {
  // In order round the extent: the south edge, the east, the north, the west.
  const glm::dvec2 corners[] = {{e.min_x, e.min_y}, {e.max_x, e.min_y}, {e.max_x, e.max_y}, {e.min_x, e.max_y}};
  std::vector<glm::dvec2> round;
  for (int edge = 0; edge < 4; ++edge) {
    const glm::dvec2 from = corners[edge], to = corners[(edge + 1) % 4];
    for (int k = 0; k < kEdgePoints; ++k) round.push_back(from + (to - from) * (double(k) / kEdgePoints));
  }
  to_lon_lat.transform(round);
  double lon = round[0].x, west = lon, east = lon, south = round[0].y, north = south;
  for (std::size_t k = 1; k <= round.size(); ++k) {
    const glm::dvec2& p = round[k % round.size()];
    lon += std::remainder(p.x - lon, 360.0);
    west = std::min(west, lon), east = std::max(east, lon);
    south = std::min(south, p.y), north = std::max(north, p.y);
  }
  // Back at the first point, a whole turn on where the edges wind round a pole.
  if (std::abs(lon - round[0].x) > 180) {
    if (south + north > 0) {
      north = 90;
    } else {
      south = -90;
    }
    return {-M_PI, glm::radians(south), M_PI, glm::radians(north)};
  }
  // The west edge turned into [-180, 180); an east edge past 180 lies across the antimeridian.
  const Extent turned = dem::turnedIntoRange({west, south, east, north});
  const double turned_east = turned.max_x > 180 ? turned.max_x - 360 : turned.max_x;
  return {glm::radians(turned.min_x), glm::radians(south), glm::radians(turned_east), glm::radians(north)};
}

// Whether the DEM's files, `areas` in the scheme's CRS, overlap `extent` by
// kTexelShareOnData of a texel each way somewhere (a DEM of a metre under a
// zoom 0 tile, a sliver of one past a tile's edge do not).
bool overlapsATexel(const std::vector<Extent>& areas, const Extent& extent, double texel_w, double texel_h) {
  return std::any_of(areas.begin(), areas.end(), [&](const Extent& area) {
    if (!area.intersects(extent)) return false;
    const Extent overlap = area.intersection(extent);
    return overlap.width() >= kTexelShareOnData * texel_w && overlap.height() >= kTexelShareOnData * texel_h;
  });
}

// Where the tile's meshes will lie, or nullopt when it holds no DEM sample.
// Every vertex of a low-poly mesh is a height sample of the tile (or the
// mean of samples across its edge), so its heights are the terrain's; the
// mesh sags below its vertices by a chord's sag at most, and skirts hang
// deeper by their depth (tile_maker.cpp), bounded here from the plan.
std::optional<io::GlbPlacement> placementOf(const LayerPlan& plan, const HeightBounds& bounds,
                                            const dem::ToLonLat& to_lon_lat, const TileId& tile) {
  const tiling::Scheme& scheme = *plan.scheme;
  const TileSettings& settings = plan.settings;
  const Extent extent = scheme.tileExtent(tile);
  const double texel = extent.width() / scheme.tileSize();
  if (!overlapsATexel(plan.file_areas, extent, texel, extent.height() / scheme.tileSize())) return std::nullopt;
  std::optional<HeightRange> heights = bounds.over(extent);
  if (!heights) return std::nullopt;
  if (heights->holes) {
    // The surface carried into the tile's holes starts from data samples up
    // to the fill's reach away, at their heights and with their slopes.
    const double reach = dem::continuationReach(settings.max_fill_px) * texel;
    const Extent around{extent.min_x - reach, extent.min_y - reach, extent.max_x + reach, extent.max_y + reach};
    if (const std::optional<HeightRange> near = bounds.over(around)) {
      heights->low_m = std::min(heights->low_m, near->low_m);
      heights->high_m = std::max(heights->high_m, near->high_m);
      heights->step_m = std::max(heights->step_m, near->step_m);
    }
  }
  // Where the tile fills holes, the surface carried into them goes beyond the
  // terrain's heights by its slope: one texel's step, estimated from the
  // fine cells' largest step and the texel's size in fine cells (no more
  // than the terrain's relief), over a share of the fill's reach.
  const double texel_cells = texel / heights->cell;
  const double texel_step_m =
      std::min(heights->step_m * std::max(1.0, texel_cells), heights->high_m - heights->low_m);
  const double fill_m = heights->holes ? kFillOvershootShare * settings.max_fill_px * texel_step_m : 0.0;
  const double low_m = heights->low_m - fill_m, high_m = heights->high_m + fill_m;
  const double relief_m = high_m - low_m;

  const LonLatBox box = lonLatOf(extent, to_lon_lat);
  const double widest_cos = box.south <= 0 && box.north >= 0 ? 1.0 : std::max(std::cos(box.south), std::cos(box.north));
  const double width_m = geo::eastwardRad(box.west, box.east) * widest_cos * geo::kMaxCurvatureRadiusM;
  const double height_m = (box.north - box.south) * geo::kMaxCurvatureRadiusM;
  const double texel_m = std::max(width_m, height_m) / scheme.tileSize();
  // No mesh edge is longer than the tile's diagonal with its relief.
  const double longest_edge_m = std::hypot(width_m, height_m, relief_m);

  // A grid mesh's distance to its samples is measured as it is made; both lie
  // within the tile's heights, so their relief bounds it.
  const bool adaptive = settings.low_poly_mesh == LowPolyMesh::kAdaptive;
  const double max_error_m = adaptive ? settings.max_error_m.at(std::size_t(tile.z)) : relief_m;
  double skirt_m = 0;
  if (settings.skirts) {
    // skirtDepthM: the zoom's and the coarser zoom's bound (a grid's: four
    // times its distance) and two texels across the ground, measured between
    // samples at their heights, where a texel spans (R + h) / R of its ground
    // size (twice that share here, for the frame's tilt away from the middle).
    const double at_height = 1 + 2 * std::max(0.0, high_m) / geo::kMinCurvatureRadiusM;
    skirt_m = skirtErrorBoundM(settings, tile.z, max_error_m) + 2 * texel_m * at_height;
  }
  const double sag_m = geo::chordSagM(longest_edge_m);
  const double bow_rad = geo::chordBowRad(longest_edge_m, std::max(-box.south, box.north));
  // A skirt hung towards the centre moves north or south as a deep point does.
  const double drift_rad = skirt_m * geo::kMaxDeflectionRad / geo::kMinCurvatureRadiusM;

  io::GlbPlacement placement;
  placement.enu_to_ecef = tileFrame(scheme, to_lon_lat, tile).localToEcef();
  placement.max_error_m = max_error_m;
  placement.region = {box.west,
                      std::max(-kHalfPi, box.south - bow_rad - drift_rad),
                      box.east,
                      std::min(kHalfPi, box.north + bow_rad + drift_rad),
                      low_m - sag_m - skirt_m,
                      high_m};
  return placement;
}

}  // namespace

std::vector<io::TilesetDocument> planTileset(const LayerPlan& plan) {
  const TileList list(plan);
  if (list.size() > kMaxPlannedTilesetTiles) {
    throw InputError("layer " + plan.layer_name + ": " + std::to_string(list.size()) + " tiles, more than the " +
                     std::to_string(kMaxPlannedTilesetTiles) +
                     " a tileset planned in memory holds; write it with `terrabake tile` and output.tileset: true");
  }
  const HeightBounds bounds(plan);
  const dem::ToLonLat to_lon_lat(plan.scheme->crs());
  std::vector<io::TilesetTile> tiles;
  for (std::uint64_t i = 0; i < list.size(); ++i) {
    const TileId tile = list.at(i);
    if (std::optional<io::GlbPlacement> placement = placementOf(plan, bounds, to_lon_lat, tile)) {
      tiles.push_back({tile, *placement});
    }
  }
  if (tiles.empty()) throw InputError("layer " + plan.layer_name + ": no tile holds a DEM sample");
  return io::buildTileset(tiles, plan.scheme->tileSize());
}

}  // namespace terrabake::pipeline

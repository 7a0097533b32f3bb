#include "pipeline/zoom_choice.hpp"

#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "dem/crs_transform.hpp"
#include "geo/local_frame.hpp"

namespace terrabake::pipeline {
namespace {

// A texel computed equal to a pixel (native grids, round numbers) must not
// lose to float noise.
constexpr double kSizeTolerance = 1e-9;

}  // namespace

double cellGroundSizeM(const std::string& crs, double x, double y, double cell_w, double cell_h) {
  std::vector<glm::dvec2> ends = {
      {x - cell_w / 2, y}, {x + cell_w / 2, y}, {x, y - cell_h / 2}, {x, y + cell_h / 2}};
  dem::ToLonLat(crs).transform(ends);
  std::vector<glm::dvec3> ecef;
  for (const glm::dvec2& p : ends) ecef.push_back(geo::geodeticToEcef(p.x, p.y, 0));
  return std::sqrt(glm::distance(ecef[0], ecef[1]) * glm::distance(ecef[2], ecef[3]));
}

double demPixelSizeM(const dem::DemSource& dem) {
  const GridSpec& g = dem.info().grid;
  return cellGroundSizeM(g.crs, g.centreX(g.width / 2.0 - 0.5), g.centreY(g.height / 2.0 - 0.5), g.cell_w,
                         g.cell_h);
}

int autoMaxZoom(const tiling::Scheme& scheme, const Extent& area, const dem::DemSource& dem) {
  if (scheme.kind() == SchemeKind::kNative) return scheme.maxZoom();
  const int tile_size = scheme.tileSize();
  const double pixel_m = demPixelSizeM(dem);
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

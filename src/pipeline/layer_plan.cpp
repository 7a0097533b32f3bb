#include "pipeline/layer_plan.hpp"

#include <algorithm>

#include "core/error.hpp"
#include "io/tile_files.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::pipeline {
namespace {

// Web Mercator stops short of the poles; tilejson bounds must too.
constexpr double kWebMercatorMaxLatDeg = 85.0511287798066;

std::shared_ptr<const tiling::Scheme> makeScheme(const config::TileJob& job, const dem::DemSource& dem) {
  if (job.scheme == "webmercator") return tiling::makeWebMercator();
  if (job.scheme == "geodetic") return tiling::makeGeodetic();
  if (job.scheme == "native") return tiling::makeNative(dem.info().grid, job.tile_size);
  throw UsageError("tiling.scheme: unsupported scheme '" + job.scheme + "'");
}

io::TileJsonInfo tileJsonInfo(const config::TileJob& job, const tiling::Scheme& scheme, const dem::DemSource& dem) {
  io::TileJsonInfo info;
  info.name = job.layer;
  info.scheme = scheme.name();
  info.tms_rows = scheme.tmsRows();
  info.min_zoom = job.min_zoom;
  info.max_zoom = job.max_zoom;
  const Extent lon_lat = dem.boundsIn("EPSG:4326");
  double south = lon_lat.min_y, north = lon_lat.max_y;
  if (scheme.name() == "webmercator") {
    south = std::max(south, -kWebMercatorMaxLatDeg);
    north = std::min(north, kWebMercatorMaxLatDeg);
  }
  info.bounds_deg = {lon_lat.min_x, south, lon_lat.max_x, north};
  info.tile_size = job.tile_size;
  info.bits = job.bits;
  info.green_up = job.green == "up";
  info.low_poly_grid = job.low_poly_grid;
  info.sources = job.dems;
  return info;
}

}  // namespace

LayerPlan planLayer(const config::TileJob& job, const dem::DemSource& dem) {
  LayerPlan plan;
  plan.scheme = makeScheme(job, dem);
  if (job.max_zoom > plan.scheme->maxZoom()) {
    throw UsageError("tiling.zoom: " + job.scheme + " tiling of '" + dem.info().path + "' has zooms 0-" +
                     std::to_string(plan.scheme->maxZoom()) + ", asked for " + std::to_string(job.max_zoom));
  }
  plan.area = dem.boundsIn(plan.scheme->crs());
  const int apron = mesh::requiredApron(job.tile_size, job.low_poly_grid);
  for (int z = job.min_zoom; z <= job.max_zoom; ++z) {
    // Judged at a tile in the middle of the DEM, the same for the whole zoom.
    const auto tiles = plan.scheme->tilesCovering(plan.area, z);
    plan.read_plans[z] = dem.planFor(plan.scheme->texelGrid(tiles[tiles.size() / 2], job.tile_size, apron));
  }
  plan.backdrop = std::make_shared<const dem::Backdrop>(dem, plan.scheme->crs());
  plan.settings.tile_size = job.tile_size;
  plan.settings.low_poly_grid = job.low_poly_grid;
  plan.settings.bits = job.bits;
  plan.settings.green = job.green == "up" ? bake::Green::kUp : bake::Green::kDown;
  plan.settings.high_res_mesh = job.high_res_mesh;
  plan.backend = gl::parseBackend(job.backend);
  plan.tilejson = io::tileJson(tileJsonInfo(job, *plan.scheme, dem));
  return plan;
}

}  // namespace terrabake::pipeline

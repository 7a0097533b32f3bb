#include "pipeline/layer_plan.hpp"

#include <algorithm>
#include <cstdio>
#include <thread>
#include <tuple>
#include <utility>

#include "core/error.hpp"
#include "dem/crs_transform.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "mesh/mesh.hpp"
#include "pipeline/zoom_choice.hpp"

namespace terrabake::pipeline {
namespace {

constexpr const char* kLonLat = "EPSG:4326";

Extent intersection(const Extent& a, const Extent& b) {
  return {std::max(a.min_x, b.min_x), std::max(a.min_y, b.min_y), std::min(a.max_x, b.max_x),
          std::min(a.max_y, b.max_y)};
}

std::string lonLatText(const Extent& e) {
  char text[128];
  std::snprintf(text, sizeof text, "lon %.8g to %.8g, lat %.8g to %.8g", e.min_x, e.max_x, e.min_y, e.max_y);
  return text;
}

// What the layer covers in longitude / latitude: the DEM's bounds, within the
// latitudes the scheme reaches and within the job's bbox.
Extent lonLatCover(const config::TileJob& job, const tiling::Scheme& scheme, const dem::DemSource& dem) {
  Extent cover = dem.boundsIn(kLonLat);
  cover.min_y = std::max(cover.min_y, -scheme.maxLatDeg());
  cover.max_y = std::min(cover.max_y, scheme.maxLatDeg());
  if (job.bbox.empty()) return cover;
  const Extent box{job.bbox[0], job.bbox[1], job.bbox[2], job.bbox[3]};
  if (!box.intersects(cover)) {
    throw UsageError("tiling.bbox: " + lonLatText(box) + " does not overlap '" + dem.info().path + "' (" +
                     lonLatText(cover) + ")");
  }
  return intersection(cover, box);
}

// The job's zooms with "auto" resolved, checked against the scheme.
std::pair<int, int> zoomRange(const config::TileJob& job, const tiling::Scheme& scheme, const Extent& dem_area,
                              const dem::DemSource& dem) {
  if (!job.max_zoom_auto) {
    if (job.max_zoom > scheme.maxZoom()) {
      throw UsageError("tiling.zoom: " + scheme.name() + " tiling of '" + dem.info().path + "' has zooms 0-" +
                       std::to_string(scheme.maxZoom()) + ", asked for " + std::to_string(job.max_zoom));
    }
    return {job.min_zoom, job.max_zoom};
  }
  const int max_zoom = autoMaxZoom(scheme, dem_area, dem);
  if (job.min_zoom > max_zoom) {
    throw UsageError("tiling.zoom: min " + std::to_string(job.min_zoom) + " is above auto's choice, " +
                     std::to_string(max_zoom) + ", for " + scheme.name() + " tiling of '" + dem.info().path + "'");
  }
  return {job.min_zoom, max_zoom};
}

io::TileJsonInfo tileJsonInfo(const config::TileJob& job, const LayerPlan& plan, const Extent& lon_lat) {
  io::TileJsonInfo info;
  info.name = job.layer;
  info.scheme = plan.scheme->kind();
  info.tms_rows = plan.scheme->tmsRows();
  info.min_zoom = plan.min_zoom;
  info.max_zoom = plan.max_zoom;
  info.bounds_deg = {lon_lat.min_x, lon_lat.min_y, lon_lat.max_x, lon_lat.max_y};
  info.tile_size = plan.scheme->tileSize();
  info.bits = job.bits;
  info.green = job.green;
  info.alpha = plan.settings.alpha;
  info.nodata_surface = job.nodata_surface;
  info.z_scale = job.z_scale;
  info.exaggeration = job.exaggeration;
  info.low_poly_mesh = job.low_poly_mesh;
  info.low_poly_grid = job.low_poly_grid;
  if (job.low_poly_mesh == LowPolyMesh::kAdaptive) {
    for (int z = plan.min_zoom; z <= plan.max_zoom; ++z) info.max_error_m[z] = plan.settings.max_error_m.at(std::size_t(z));
  }
  info.sources = job.dems;
  return info;
}

TileSettings tileSettings(const config::TileJob& job) {
  TileSettings settings;
  const bool grid = job.low_poly_mesh == LowPolyMesh::kGrid;
  settings.apron = grid ? mesh::requiredApron(job.tile_size, job.low_poly_grid) : mesh::kAdaptiveApron;
  settings.low_poly_mesh = job.low_poly_mesh;
  settings.low_poly_grid = job.low_poly_grid;
  settings.bits = job.bits;
  settings.green = job.green;
  settings.high_res_mesh = job.high_res_mesh;
  // A cut needs alpha: it is what tells a renderer where nothing is.
  settings.alpha = job.alpha || job.nodata_surface == NodataSurface::kCut;
  settings.height_scale = job.z_scale * job.exaggeration;
  settings.max_fill_px = job.max_fill_px;
  settings.nodata_surface = job.nodata_surface;
  return settings;
}

// The adaptive mesh's bound at each zoom: max_error_m, or max_error_texels
// of the zoom's texel size on the ground in the middle of the DEM (whatever
// the bbox, so a bbox run writes the bytes a whole run does).
std::vector<double> maxErrorByZoom(const config::TileJob& job, const tiling::Scheme& scheme, const Extent& dem_area,
                                   int max_zoom) {
  std::vector<double> bounds;
  const double x = (dem_area.min_x + dem_area.max_x) / 2, y = (dem_area.min_y + dem_area.max_y) / 2;
  for (int z = 0; z <= max_zoom; ++z) {
    const tiling::LevelGrid level = scheme.levelGrid(z);
    const double texel_m =
        cellGroundSizeM(scheme.crs(), x, y, level.tile_w / scheme.tileSize(), level.tile_h / scheme.tileSize());
    bounds.push_back(job.max_error_m > 0 ? job.max_error_m : job.max_error_texels * texel_m);
  }
  return bounds;
}

}  // namespace

LayerPlan planLayer(const config::TileJob& job) {
  config::validate(job, "job");
  const dem::DemSource dem(job.dems);
  LayerPlan plan;
  plan.dem_paths = job.dems;
  plan.scheme = tiling::makeScheme(job.scheme, job.tile_size, &dem.info().grid);
  plan.settings = tileSettings(job);
  const Extent dem_area = dem.boundsIn(plan.scheme->crs());
  std::tie(plan.min_zoom, plan.max_zoom) = zoomRange(job, *plan.scheme, dem_area, dem);
  if (job.low_poly_mesh == LowPolyMesh::kAdaptive) {
    plan.settings.max_error_m = maxErrorByZoom(job, *plan.scheme, dem_area, plan.max_zoom);
  }
  const Extent lon_lat = lonLatCover(job, *plan.scheme, dem);
  plan.area = job.bbox.empty()
                  ? dem_area
                  : intersection(dem_area, dem::transformExtent(lon_lat, kLonLat, plan.scheme->crs()));
  for (int z = plan.min_zoom; z <= plan.max_zoom; ++z) {
    // Judged at a tile in the middle of the DEM, the same for the whole zoom
    // whatever the bbox, so a bbox run writes the bytes a whole run does.
    const auto tiles = plan.scheme->tilesCovering(dem_area, z);
    plan.read_plans[z] = dem.planFor(plan.scheme->texelGrid(tiles[tiles.size() / 2], plan.settings.apron));
  }
  plan.backdrop = std::make_shared<const dem::Backdrop>(dem, plan.scheme->crs());
  plan.backend = job.backend;
  plan.workers = job.workers > 0 ? job.workers : int(std::max(1u, std::thread::hardware_concurrency()));
  plan.layer_name = job.layer;
  plan.format = job.format;
  plan.location = io::layerLocation(job.output_dir, job.layer, job.format);
  plan.fingerprint = config::layerFingerprint(job);
  plan.tilejson = io::tileJson(tileJsonInfo(job, plan, lon_lat));
  return plan;
}

}  // namespace terrabake::pipeline

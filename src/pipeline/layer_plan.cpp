#include "pipeline/layer_plan.hpp"

#include <algorithm>
#include <cstdio>
#include <tuple>
#include <utility>

#include "core/error.hpp"
#include "core/extent_groups.hpp"
#include "core/log.hpp"
#include "core/usable_cores.hpp"
#include "dem/crs_transform.hpp"
#include "geo/region.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "mesh/mesh.hpp"
#include "pipeline/zoom_choice.hpp"

namespace terrabake::pipeline {
namespace {

constexpr const char* kLonLat = "EPSG:4326";

std::string lonLatText(const Extent& e) {
  char text[128];
  std::snprintf(text, sizeof text, "lon %.8g to %.8g, lat %.8g to %.8g", e.min_x, e.max_x, e.min_y, e.max_y);
  return text;
}

// What the layer covers in longitude / latitude: the DEM's bounds, within the
// latitudes the scheme reaches and within the job's bbox, in one piece or
// two (across the antimeridian). Throws NothingToMake when nothing is left.
std::vector<Extent> lonLatCover(const config::TileJob& job, const tiling::Scheme& scheme,
                                const dem::DemSource& dem) {
  const Extent bounds = dem.boundsIn(kLonLat);
  const std::vector<Extent> cover = lonLatPieces(bounds, scheme.maxLatDeg());
  if (cover.empty()) {
    char lat[96];
    std::snprintf(lat, sizeof lat, "lat %.8g to %.8g", bounds.min_y, bounds.max_y);
    throw NothingToMake("nothing to make: '" + shortened(dem.info().path) + "' (" + lat + ") lies beyond the " +
                        "latitudes " + scheme.name() + " tiles reach (" + std::to_string(scheme.maxLatDeg()) +
                        " north and south)" + (scheme.maxLatDeg() < 90 ? "; use --scheme geodetic or native" : ""));
  }
  if (job.bbox.empty()) return cover;
  const Extent box{job.bbox[0], job.bbox[1], job.bbox[2], job.bbox[3]};
  // West above east: the box runs across the antimeridian, in a piece each side.
  const std::vector<Extent> box_pieces =
      box.min_x < box.max_x ? std::vector<Extent>{box}
                            : std::vector<Extent>{{box.min_x, box.min_y, 180, box.max_y}, {-180, box.min_y, box.max_x, box.max_y}};
  if (box_pieces.size() > 1) {
    // Said, since a box with west and east swapped by mistake reads so too.
    log::info("tiling.bbox: west above east, so the box runs across the antimeridian: " +
              lonLatText(box_pieces[0]) + " and " + lonLatText(box_pieces[1]));
  }
  std::vector<Extent> inside;
  for (const Extent& piece : cover) {
    for (const Extent& box_piece : box_pieces) {
      if (box_piece.intersects(piece)) inside.push_back(piece.intersection(box_piece));
    }
  }
  if (inside.empty()) {
    const auto united = [](const std::vector<Extent>& pieces) {
      Extent all = pieces.front();
      for (const Extent& piece : pieces) all = all.united(piece);
      return all;
    };
    // The box may overlap the DEM beyond the scheme's latitudes.
    const std::vector<Extent> whole = lonLatPieces(bounds, 90);
    bool beyond_map = false;
    for (const Extent& piece : whole) {
      for (const Extent& box_piece : box_pieces) beyond_map = beyond_map || box_piece.intersects(piece);
    }
    const std::string name = "'" + shortened(dem.info().path) + "'";
    throw NothingToMake("tiling.bbox: " + lonLatText(box) + " does not overlap " +
                        (beyond_map ? "the part of " + name + " that " + scheme.name() + " tiles reach (" +
                                          lonLatText(united(cover)) + "; use --scheme geodetic or native for the rest)"
                                    : name + " (" + lonLatText(united(whole)) + ")") +
                        ": nothing to make");
  }
  return inside;
}

// The parts of `areas` (the DEM's files) within `box_areas` (tiling.bbox's
// pieces). Throws NothingToMake when the box lies between the files.
std::vector<Extent> within(const std::vector<Extent>& areas, const std::vector<Extent>& box_areas,
                           const config::TileJob& job, const dem::DemSource& dem) {
  std::vector<Extent> parts;
  for (const Extent& area : areas) {
    for (const Extent& box : box_areas) {
      if (box.intersects(area)) parts.push_back(area.intersection(box));
    }
  }
  if (parts.empty()) {
    throw NothingToMake("tiling.bbox: " + lonLatText({job.bbox[0], job.bbox[1], job.bbox[2], job.bbox[3]}) +
                        " lies between the files of '" + shortened(dem.info().path) + "': nothing to make");
  }
  return mergeMeeting(parts);
}

// The job's zooms with "auto" resolved, checked against the scheme.
std::pair<int, int> zoomRange(const config::TileJob& job, const tiling::Scheme& scheme,
                              const std::vector<FileGroup>& groups, const dem::DemSource& dem) {
  if (!job.max_zoom_auto) {
    if (job.max_zoom > scheme.maxZoom()) {
      throw UsageError("tiling.zoom: " + scheme.name() + " tiling of '" + dem.info().path + "' has zooms 0-" +
                       std::to_string(scheme.maxZoom()) + ", asked for " + std::to_string(job.max_zoom));
    }
    return {job.min_zoom, job.max_zoom};
  }
  const int max_zoom = autoMaxZoom(scheme, groups, dem);
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
  info.skirts = plan.settings.skirts;
  info.tileset = plan.tileset;
  if (job.low_poly_mesh == LowPolyMesh::kAdaptive) {
    for (int z = plan.min_zoom; z <= plan.max_zoom; ++z) info.max_error_m[z] = plan.settings.max_error_m.at(std::size_t(z));
  }
  info.sources = job.dems;
  info.elevation = job.elevation;
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
  settings.skirts = job.skirts == Skirts::kOn || (job.skirts == Skirts::kAuto && job.tileset);
  settings.elevation = job.elevation;
  return settings;
}

// The adaptive mesh's bound at each zoom: max_error_m, or max_error_texels
// of the zoom's texel size on the ground in the middle of `area`, the first
// file's group (whatever the bbox, so a bbox run writes the bytes a whole
// run does).
std::vector<double> maxErrorByZoom(const config::TileJob& job, const tiling::Scheme& scheme, const Extent& area,
                                   int max_zoom) {
  std::vector<double> bounds;
  const double x = (area.min_x + area.max_x) / 2, y = (area.min_y + area.max_y) / 2;
  for (int z = 0; z <= max_zoom; ++z) {
    const tiling::LevelGrid level = scheme.levelGrid(z);
    const double texel_m =
        cellGroundSizeM(scheme.crs(), x, y, level.tile_w / scheme.tileSize(), level.tile_h / scheme.tileSize());
    bounds.push_back(job.max_error_m > 0 ? job.max_error_m : job.max_error_texels * texel_m);
  }
  return bounds;
}

// The narrowest run of longitudes that holds every piece, west above east
// where it runs across the antimeridian (the pieces of a DEM across it), and
// their latitudes. Pieces that a box with west above east leaves either
// side of its gap, both east of the antimeridian, are bounded between them.
Extent lonLatBoundsOf(const std::vector<Extent>& pieces) {
  Extent bounds = pieces.front();
  std::vector<std::pair<double, double>> arcs;
  for (const Extent& piece : pieces) {
    bounds.min_y = std::min(bounds.min_y, piece.min_y), bounds.max_y = std::max(bounds.max_y, piece.max_y);
    arcs.emplace_back(piece.min_x, piece.max_x);
  }
  const auto run = geo::narrowestRunHolding(std::move(arcs));
  bounds.min_x = run ? run->first : -180;
  bounds.max_x = !run ? 180 : run->second > 180 ? run->second - 360 : run->second;
  return bounds;
}

// What the settings cannot do together, said before the DEM is opened.
void checkOutputs(const config::TileJob& job) {
  if (job.elevation != Elevation::kNone) {
    const std::string encoding(wordOf(job.elevation));
    if (job.scheme != SchemeKind::kWebMercator) {
      throw UsageError("output.elevation: " + encoding +
                       " tiles are MapLibre raster-dem tiles, which only the webmercator scheme makes; "
                       "tiling.scheme is " + std::string(wordOf(job.scheme)));
    }
    if (job.format == OutputFormat::kMbtiles) {
      throw UsageError("output.elevation: an MBTiles layer holds no elevation tiles; use output.format files or "
                       "pmtiles");
    }
  }
  if (job.tileset && job.format == OutputFormat::kPmtiles) {
    throw UsageError("output.tileset: a PMTiles layer holds no tileset (3D Tiles viewers fetch each file by its "
                     "URL); use output.format files or mbtiles");
  }
  if (job.format == OutputFormat::kPmtiles && job.scheme == SchemeKind::kGeodetic) {
    // A tile id is a place on a Hilbert curve over 2^z x 2^z tiles; a
    // geodetic zoom has twice as many columns, which no id tells apart.
    throw UsageError(
        "output.format: a PMTiles archive holds 2^z columns of tiles at zoom z and the geodetic scheme "
        "makes twice as many; use output.format files or mbtiles, or tiling.scheme webmercator");
  }
  if (job.format == OutputFormat::kPmtiles && io::isPmtilesCompanion(job.layer + io::kPmtilesExtension)) {
    throw UsageError("output.layer: '" + job.layer + "' ends like the name of a layer's companion archive "
                     "(.meshes, .hires, .elevation); choose another name for a pmtiles layer");
  }
}

}  // namespace

LayerPlan planLayer(const config::TileJob& job) {
  config::validate(job, "job");
  checkOutputs(job);
  dem::DemOptions options;
  options.band = job.band;
  options.min_height = dem::kMinPlausibleHeightM / job.z_scale;
  options.max_height = dem::kMaxPlausibleHeightM / job.z_scale;
  options.metres_per_unit = job.z_scale;
  const auto dem = std::make_shared<const dem::DemSource>(job.dems, options);
  for (const std::string& warning : dem->warnings()) log::warning(warning);
  LayerPlan plan;
  plan.dem = dem;
  plan.scheme = tiling::makeScheme(job.scheme, job.tile_size, &dem->info().grid);
  plan.settings = tileSettings(job);
  const std::vector<Extent> lon_lat = lonLatCover(job, *plan.scheme, *dem);
  // lonLatCover found the DEM within the scheme's latitudes: it has an area.
  const std::vector<Extent> dem_areas = demAreas(*plan.scheme, *dem);
  // The native grid is the DEM's own, one area whatever the longitudes.
  const bool across = plan.scheme->kind() != SchemeKind::kNative && (dem_areas.size() > 1 || lon_lat.size() > 1);
  const std::vector<FileGroup> groups = fileGroups(*plan.scheme, *dem);
  plan.file_areas = groupAreas(groups);
  std::tie(plan.min_zoom, plan.max_zoom) = zoomRange(job, *plan.scheme, groups, *dem);
  if (job.low_poly_mesh == LowPolyMesh::kAdaptive) {
    plan.settings.max_error_m = maxErrorByZoom(job, *plan.scheme, groups[groupJudging(groups, 0)].area, plan.max_zoom);
  }
  if (job.bbox.empty()) {
    plan.areas = plan.file_areas;
  } else {
    std::vector<Extent> box_areas;
    if (across) {
      for (const Extent& piece : lon_lat) box_areas.push_back(*plan.scheme->fromLonLat(piece));
    } else {
      box_areas.push_back(dem::transformExtent(lon_lat.front(), kLonLat, plan.scheme->crs()));
    }
    plan.areas = within(plan.file_areas, box_areas, job, *dem);
  }
  plan.area = plan.areas.front();
  for (const Extent& area : plan.areas) plan.area = plan.area.united(area);
  std::vector<std::size_t> group_of(dem->fileCount());
  for (std::size_t file = 0; file < group_of.size(); ++file) group_of[file] = groupJudging(groups, file);
  for (int z = plan.min_zoom; z <= plan.max_zoom; ++z) {
    // Each file judged at a tile in the middle of its group, the same for the
    // whole zoom whatever the bbox, so a bbox run writes the bytes a whole
    // run does, and a file listed with others far away those of its own run.
    std::map<std::size_t, GridSpec> middles;
    for (const std::size_t g : group_of) {
      if (middles.count(g)) continue;
      const tiling::TileRange tiles = plan.scheme->rangeCovering(groups[g].area, z);
      const TileId middle = plan.scheme->tileAt(tiles, tiles.count() / 2);
      middles[g] = plan.scheme->texelGrid(middle, plan.settings.apron);
    }
    plan.read_plans[z] = dem->planFor([&](std::size_t file) -> const GridSpec& { return middles.at(group_of[file]); });
  }
  std::vector<std::vector<std::size_t>> groups_of_files;
  for (const FileGroup& group : groups) {
    if (!group.files.empty()) groups_of_files.push_back(group.files);
  }
  plan.backdrop =
      std::make_shared<const dem::Backdrop>(*dem, plan.scheme->crs(), plan.scheme->globe(), groups_of_files);
  dem->closeFiles();  // the workers open their own
  plan.backend = job.backend;
  plan.workers = job.workers > 0 ? job.workers : usableCores().count;
  if (job.workers == 0 && !usableCores().limited_by.empty()) {
    log::info("bake.workers: " + std::to_string(plan.workers) + ", one per CPU this process may use (" +
              usableCores().limited_by + ")");
  }
  plan.layer_name = job.layer;
  plan.format = job.format;
  plan.location = io::layerLocation(job.output_dir, job.layer, job.format);
  plan.fingerprint = config::layerFingerprint(job);
  plan.tileset = job.tileset;
  const io::TileJsonInfo info = tileJsonInfo(job, plan, lonLatBoundsOf(lon_lat));
  plan.tilejson = io::tileJson(info);
  if (job.elevation != Elevation::kNone) plan.elevation_tilejson = io::elevationTileJson(info);
  return plan;
}

TileList::TileList(const LayerPlan& plan) : m_scheme(plan.scheme) {
  for (int z = plan.min_zoom; z <= plan.max_zoom; ++z) {
    for (const tiling::TileRange& range : plan.scheme->rangesCovering(plan.areas, z)) {
      m_ranges.push_back(range);
      m_starts.push_back(m_size);
      m_size += range.count();
    }
  }
}

std::uint64_t TileList::sizeAt(int zoom) const {
  std::uint64_t count = 0;
  for (const tiling::TileRange& range : m_ranges) count += range.zoom == zoom ? range.count() : 0;
  return count;
}

TileId TileList::at(std::uint64_t index) const {
  const auto next = std::upper_bound(m_starts.begin(), m_starts.end(), index);
  const std::size_t k = std::size_t(next - m_starts.begin()) - 1;
  return m_scheme->tileAt(m_ranges[k], index - m_starts[k]);
}

double skirtErrorBoundM(const TileSettings& settings, int z, double grid_error_m) {
  if (settings.low_poly_mesh != LowPolyMesh::kAdaptive) return 4 * grid_error_m;
  return std::max(settings.max_error_m.at(std::size_t(std::max(0, z - 1))), settings.max_error_m.at(std::size_t(z)));
}

}  // namespace terrabake::pipeline

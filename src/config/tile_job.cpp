#include "config/tile_job.hpp"

#include <algorithm>
#include <exception>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "config/key_table.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "core/types.hpp"

namespace terrabake::config {
namespace {

namespace kt = key_table;
using kt::choice;
using kt::number;
using kt::text;

bool hasPaths(const std::vector<std::string>& paths) { return !paths.empty(); }

// tiling.zoom sets both ends, "auto" and whether it was given at all.
kt::Field<TileJob> zoomField() {
  kt::Field<TileJob> field;
  field.parse = [](const kt::KeySpec& key, const kt::Value& value, TileJob& job) {
    const kt::ZoomRange range = kt::parseZoom(key, value);
    job.min_zoom = range.min_zoom;
    job.max_zoom = range.max_zoom;
    job.max_zoom_auto = range.max_auto;
    job.zoom_set = true;
  };
  field.problem = [](const TileJob& job) {
    return job.zoom_set ? kt::zoomProblem(job.min_zoom, job.max_zoom, job.max_zoom_auto) : "";
  };
  field.text = [](const TileJob& job) {
    return std::to_string(job.min_zoom) + "-" +
           (job.max_zoom_auto ? std::string("auto") : std::to_string(job.max_zoom));
  };
  field.is_set = [](const TileJob& job) { return job.zoom_set; };
  return field;
}

// The one table of keys: files, flags, overrides, validate(), --help and
// listKeys() all read it. config_test checks config/README.md against it.
const kt::KeyTable<TileJob>& table() {
  static const kt::KeyTable<TileJob> kTable({
      {"dem", "--dem", "path or list of paths", "DEM file(s) to tile, any format GDAL reads",
       text(&TileJob::dems, kt::parsePaths, kt::pathsProblem, kt::joinPaths, hasPaths)},
      {"output.dir", "--out", "path", "folder that holds the layers",
       text(&TileJob::output_dir, kt::parsePath, kt::pathProblem, kt::writeText)},
      {"output.layer", "--layer", "folder name",
       "layer folder under output.dir: letters, digits, '.', '_' and '-', at most 128 bytes, not '.' or '..'",
       text(&TileJob::layer, kt::parseWord, kt::layerNameProblem, kt::writeText)},
      {"output.format", "--format", "string",
       "how the layer is stored: files (a folder of {z}/{x}/{y} files), mbtiles (one SQLite file) or pmtiles "
       "(one PMTiles v3 archive per kind of tile)",
       choice(&TileJob::format)},
      {"output.bits", "--bits", "integer", "bits per channel of the normal-map PNGs: 8 or 16",
       number(&TileJob::bits, 8, 16, {8, 16})},
      {"output.green", "--green", "string",
       "where +Y of tangent space points: up (OpenGL, glTF) or down (DirectX)", choice(&TileJob::green)},
      {"output.high_res_mesh", "--high-res-mesh", "boolean",
       "also write {y}.hires.glb, the full-resolution surface, for viewers that compare",
       choice(&TileJob::high_res_mesh)},
      {"output.alpha", "--alpha", "boolean",
       "RGBA normal maps: alpha 0 where the DEM has no valid sample (holes, outside it), else opaque",
       choice(&TileJob::alpha)},
      {"output.tileset", "--tileset", "boolean",
       "also write tileset.json (OGC 3D Tiles 1.1) over the meshes, for CesiumJS, 3d-tiles-renderer and other "
       "3D Tiles viewers",
       choice(&TileJob::tileset)},
      {"output.elevation", "--elevation", "string",
       "also write {y}.elevation.png, the heights the tile was baked from, for MapLibre's raster-dem: none, "
       "terrarium or mapbox (Terrain-RGB); webmercator only",
       choice(&TileJob::elevation)},
      {"tiling.scheme", "--scheme", "string",
       "tile grid: webmercator (EPSG:3857, XYZ), geodetic (EPSG:4326, TMS) or native "
       "(the DEM's own grid)",
       choice(&TileJob::scheme)},
      {"tiling.zoom", "--zoom", "integer, [min, max], \"min-max\" or auto",
       "zoom levels to make, 0.." + std::to_string(kMaxZoom) +
           "; auto as max: the deepest zoom whose texels are no smaller than the DEM's pixels (auto alone: "
           "0-auto)",
       zoomField()},
      {"tiling.bbox", "--bbox", "[west, south, east, north]",
       "only tiles that intersect this box, degrees of longitude and latitude (WGS84); none: no box",
       text(&TileJob::bbox, kt::parseBox, kt::boxProblem, kt::boxText)},
      {"tiling.tile_size", "--tile-size", "integer", "texels a side of each normal map, 16..4096",
       number(&TileJob::tile_size, 16, 4096)},
      {"heights.band", "--band", "integer",
       "the band of each DEM file that holds heights, 1..65535 (a file with more bands is warned about)",
       number(&TileJob::band, 1, 65535)},
      {"heights.z_scale", "--z-scale", "number",
       "metres per DEM height unit (0.3048 for feet), above 0 and at most 1000",
       number(&TileJob::z_scale, 0.0, 1000.0, {}, true)},
      {"heights.exaggeration", "--exaggeration", "number",
       "vertical exaggeration of the normal maps and meshes, above 0 and at most 100",
       number(&TileJob::exaggeration, 0.0, 100.0, {}, true)},
      {"nodata.max_fill_px", "--max-fill", "integer",
       "texels over which the surface carried on into a hole fades into the coarse backdrop; 0..512",
       number(&TileJob::max_fill_px, 0, 512)},
      {"nodata.surface", "--nodata-surface", "string",
       "where the DEM has no sample: continue (the surface runs on from the data without a step) or cut "
       "(alpha 0 and no triangles there, so nothing is drawn)",
       choice(&TileJob::nodata_surface)},
      {"low_poly.mesh", "--low-poly", "string",
       "each tile's low-poly mesh: adaptive (a crack-free triangulation of the heights within a distance bound) "
       "or grid (low_poly.grid vertices a side)",
       choice(&TileJob::low_poly_mesh)},
      {"low_poly.max_error_m", "--max-error", "number",
       "adaptive: the largest distance in metres between any height sample and the mesh, the same at every "
       "zoom, 0..100000; 0: low_poly.max_error_texels at each zoom instead",
       number(&TileJob::max_error_m, 0.0, 100000.0)},
      {"low_poly.max_error_texels", "--max-error-texels", "number",
       "adaptive, when low_poly.max_error_m is 0: the bound at each zoom as a multiple of that zoom's texel "
       "size on the ground (so it halves from one zoom to the next), above 0 and at most 1000",
       number(&TileJob::max_error_texels, 0.0, 1000.0, {}, true)},
      {"low_poly.grid", "--low-poly-grid", "integer", "grid: vertices a side of each tile's low-poly mesh, 2..257",
       number(&TileJob::low_poly_grid, 2, 257)},
      {"low_poly.skirts", "--skirts", "string",
       "walls hanging under each mesh's edges, so no gap shows where tiles of two zooms meet: on, off, or "
       "auto (on with output.tileset)",
       choice(&TileJob::skirts)},
      {"bake.backend", "--backend", "string",
       "how normals are baked: auto (terrabake picks), osmesa or egl (GL), cpu (no GL)",
       choice(&TileJob::backend)},
      {"bake.workers", "--workers", "integer", "tiles baked in parallel, 0 = one per core the process may use, 0..256",
       number(&TileJob::workers, 0, 256)},
  });
  return kTable;
}

}  // namespace

TileJob loadTileJob(const std::string& yaml_path) { return table().load(yaml_path); }

TileJob parseTileJob(const std::string& yaml_text, const std::string& yaml_path) {
  return table().loadText(yaml_text, yaml_path);
}

std::string layerFingerprint(const TileJob& job) { return table().describe(job, {"output.dir", "bake.workers"}); }

namespace {

// A refusal names this many differences: a record of quite another job
// differs in most keys, and one line should stay readable.
constexpr std::size_t kMaxNamedDifferences = 3;

// A fingerprint's "key: value" lines as (key, value), in their order.
std::vector<std::pair<std::string, std::string>> fingerprintLines(const std::string& fingerprint) {
  std::vector<std::pair<std::string, std::string>> lines;
  std::istringstream in(fingerprint);
  for (std::string line; std::getline(in, line);) {
    const std::size_t colon = line.find(": ");
    if (colon != std::string::npos) lines.emplace_back(line.substr(0, colon), line.substr(colon + 2));
  }
  return lines;
}

struct ZoomText {
  int min_zoom = 0;
  std::string max_zoom;  // a number or "auto"
};

// "8-12" or "8-auto", as zoomField() writes it.
std::optional<ZoomText> parsedZoomText(const std::string& text) {
  const std::size_t dash = text.find('-');
  if (dash == std::string::npos || dash == 0) return std::nullopt;
  ZoomText zoom;
  try {
    zoom.min_zoom = std::stoi(text.substr(0, dash));
  } catch (const std::exception&) {
    return std::nullopt;
  }
  zoom.max_zoom = text.substr(dash + 1);
  return zoom;
}

bool zoomsHold(const std::string& outer, const std::string& inner) {
  const std::optional<ZoomText> a = parsedZoomText(outer), b = parsedZoomText(inner);
  if (!a || !b || a->min_zoom > b->min_zoom) return false;
  if (a->max_zoom == b->max_zoom) return true;
  if (a->max_zoom == "auto" || b->max_zoom == "auto") return false;  // auto's zoom depends on the DEM
  try {
    return std::stoi(a->max_zoom) >= std::stoi(b->max_zoom);
  } catch (const std::exception&) {
    return false;
  }
}

// "none" or "[west, south, east, north]", as boxText() writes it; a box
// across the antimeridian (west above east) holds only itself.
bool boxesHold(const std::string& outer, const std::string& inner) {
  if (outer == inner || outer == "none") return true;
  if (inner == "none") return false;
  const auto corners = [](const std::string& text) {
    std::vector<double> values;
    std::istringstream in(text.substr(1));
    for (double v; in >> v;) {
      values.push_back(v);
      in.ignore(2, ' ');
    }
    return values;
  };
  const std::vector<double> a = corners(outer), b = corners(inner);
  if (a.size() != 4 || b.size() != 4 || a[0] > a[2] || b[0] > b[2]) return false;
  return a[0] <= b[0] && a[1] <= b[1] && a[2] >= b[2] && a[3] >= b[3];
}

}  // namespace

bool growsLayer(const std::string& recorded, const std::string& wanted) {
  const auto there = fingerprintLines(recorded), here = fingerprintLines(wanted);
  if (there.size() != here.size() || there.empty()) return false;
  // Keys a job with this low-poly mesh does not read: no byte depends on them.
  std::string mesh, max_error_m;
  for (const auto& [key, value] : here) {
    if (key == "low_poly.mesh") mesh = value;
    if (key == "low_poly.max_error_m") max_error_m = value;
  }
  const auto unread = [&](const std::string& key) {
    if (mesh == "adaptive") return key == "low_poly.grid" || (key == "low_poly.max_error_texels" && max_error_m != "0");
    return mesh == "grid" && (key == "low_poly.max_error_m" || key == "low_poly.max_error_texels");
  };
  for (std::size_t k = 0; k < here.size(); ++k) {
    const auto& [key, value] = here[k];
    const auto& [recorded_key, recorded_value] = there[k];
    if (key != recorded_key) return false;
    if (key == "tiling.zoom"   ? !zoomsHold(value, recorded_value)
        : key == "tiling.bbox" ? !boxesHold(value, recorded_value)
                               : value != recorded_value && !unread(key)) {
      return false;
    }
  }
  return true;
}

bool claimLayerOfAnotherJob(const std::string& layer, const std::string& recorded, const std::string& wanted,
                            bool force, const std::string& remedy, const std::string& grown_note) {
  const std::string differences = fingerprintDifferences(recorded, wanted);
  if (growsLayer(recorded, wanted)) {
    log::info(layer + " grows (" + differences + "); the tiles it holds are this job's too" + grown_note);
    return true;
  }
  if (force) return false;
  throw UsageError(layer + " was made by a different job" + (differences.empty() ? "" : " (" + differences + ")") +
                   "; " + remedy);
}

std::string fingerprintDifferences(const std::string& recorded, const std::string& wanted) {
  const auto there = fingerprintLines(recorded), here = fingerprintLines(wanted);
  const auto valueIn = [](const auto& lines, const std::string& key) -> std::string {
    for (const auto& [k, v] : lines) {
      if (k == key) return v;
    }
    return "none";
  };
  std::vector<std::string> differences;
  const auto compare = [&](const std::string& key) {
    const std::string a = valueIn(there, key), b = valueIn(here, key);
    const std::string difference = key + ": " + a + " there, " + b + " here";
    if (a != b && std::find(differences.begin(), differences.end(), difference) == differences.end()) {
      differences.push_back(difference);
    }
  };
  for (const auto& line : here) compare(line.first);
  for (const auto& line : there) compare(line.first);
  std::string text;
  for (std::size_t k = 0; k < std::min(differences.size(), kMaxNamedDifferences); ++k) {
    text += (k ? "; " : "") + differences[k];
  }
  if (differences.size() > kMaxNamedDifferences) {
    text += "; and " + std::to_string(differences.size() - kMaxNamedDifferences) + " more";
  }
  return text;
}

void applyOverride(TileJob& job, const std::string& key, const std::vector<std::string>& values,
                   const std::string& origin) {
  table().applyOverride(job, key, values, origin);
}

void validate(const TileJob& job, const std::string& origin) { table().validate(job, origin); }

std::vector<KeyInfo> listKeys() { return table().list(); }

}  // namespace terrabake::config

#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "io/tileset.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;  // keeps the key order the file was written in

// The version of docs/CONTRACT.md the layer follows.
constexpr const char* kFormatVersion = "5";

// Middle longitude of [west, east], also when the bounds cross the antimeridian
// (west > east).
double middleLongitude(double west, double east) {
  if (west > east) east += 360;
  double mid = (west + east) / 2;
  if (mid >= 180) mid -= 360;
  return mid;
}

Json parseObject(const std::string& text) {
  Json doc = Json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) throw std::runtime_error("not a JSON object");
  return doc;
}

// "./{z}/{x}/{y}.png" or "{z}/{x}/{y}.png" under the layer; "http://..." and
// "/..." are left alone.
std::string resolve(const std::string& url, const std::string& layer_url) {
  if (url.find("://") != std::string::npos || url.rfind('/', 0) == 0) return url;
  return layer_url + (url.rfind("./", 0) == 0 ? url.substr(2) : url);
}

// What a renderer choosing between levels needs of the meshes: the kind,
// and for adaptive meshes each zoom's distance bound in metres.
Json lowPolyJson(const TileJsonInfo& info) {
  Json low_poly = {{"mesh", std::string(wordOf(info.low_poly_mesh))}};
  if (info.low_poly_mesh == LowPolyMesh::kGrid) {
    low_poly["grid"] = info.low_poly_grid;
  } else {
    Json bounds = Json::object();
    for (const auto& [zoom, metres] : info.max_error_m) bounds[std::to_string(zoom)] = metres;
    low_poly["max_error_m"] = bounds;
  }
  low_poly["skirts"] = info.skirts;
  return low_poly;
}

constexpr const char* kElevationTiles = "./{z}/{x}/{y}.elevation.png";

// Resolves the string at `key` of `object`, when there is one.
void resolveKey(Json& object, const char* key, const std::string& layer_url) {
  const auto url = object.find(key);
  if (url != object.end() && url->is_string()) *url = resolve(url->get<std::string>(), layer_url);
}

}  // namespace

std::string tileJson(const TileJsonInfo& info) {
  const auto& b = info.bounds_deg;
  for (double v : b) {
    if (!std::isfinite(v)) throw std::invalid_argument("tileJson: bounds are not finite");
  }
  if (info.min_zoom < 0 || info.min_zoom > info.max_zoom) {
    throw std::invalid_argument("tileJson: zoom range is empty or negative");
  }

  Json doc = {
      {"tilejson", "3.0.0"},
      {"name", info.name},
      {"scheme", info.tms_rows ? "tms" : "xyz"},
      {"tiles", {"./{z}/{x}/{y}.png"}},
      {"minzoom", info.min_zoom},
      {"maxzoom", info.max_zoom},
      {"bounds", {b[0], b[1], b[2], b[3]}},
      // The deepest zoom, where the layer's full detail shows.
      {"center", {middleLongitude(b[0], b[2]), (b[1] + b[3]) / 2, info.max_zoom}},
      {"terrabake",
       {{"version", kFormatVersion},
        {"scheme", std::string(wordOf(info.scheme))},
        {"tile_size", info.tile_size},
        {"bits", info.bits},
        {"green", std::string(wordOf(info.green))},
        {"alpha", info.alpha},
        {"nodata_surface", std::string(wordOf(info.nodata_surface))},
        {"z_scale", info.z_scale},
        {"exaggeration", info.exaggeration},
        {"mesh", "./{z}/{x}/{y}.glb"},
        {"low_poly", lowPolyJson(info)},
        {"sources", info.sources}}},
  };
  if (info.tileset) doc["terrabake"]["tileset"] = std::string("./") + kTilesetFile;
  if (info.elevation != Elevation::kNone) {
    doc["terrabake"]["elevation"] = {{"encoding", std::string(wordOf(info.elevation))},
                                     {"tiles", kElevationTiles},
                                     {"tilejson", std::string("./") + kElevationTileJsonFile}};
  }
  return doc.dump(2) + "\n";
}

std::string elevationTileJson(const TileJsonInfo& info) {
  const auto& b = info.bounds_deg;
  const Json doc = {
      {"tilejson", "3.0.0"},
      {"name", info.name},
      {"scheme", "xyz"},
      {"tiles", {kElevationTiles}},
      {"minzoom", info.min_zoom},
      {"maxzoom", info.max_zoom},
      {"bounds", {b[0], b[1], b[2], b[3]}},
      {"center", {middleLongitude(b[0], b[2]), (b[1] + b[3]) / 2, info.max_zoom}},
      // What MapLibre's raster-dem source reads besides TileJSON's keys.
      {"encoding", std::string(wordOf(info.elevation))},
      {"tileSize", info.tile_size},
  };
  return doc.dump(2) + "\n";
}

TileJsonSummary readTileJson(const std::string& text) {
  const Json doc = parseObject(text);
  TileJsonSummary summary;
  try {
    summary.min_zoom = doc.at("minzoom").get<int>();
    summary.max_zoom = doc.at("maxzoom").get<int>();
    summary.bounds_deg = doc.at("bounds").get<std::array<double, 4>>();
  } catch (const Json::exception& e) {
    throw std::runtime_error(std::string("minzoom, maxzoom or bounds: ") + e.what());
  }
  // TileJSON's "scheme": "tms" when y counts from the south; "xyz", the default, otherwise.
  const auto rows = doc.find("scheme");
  summary.tms_rows = rows != doc.end() && rows->is_string() && rows->get<std::string>() == "tms";
  const auto terrabake = doc.find("terrabake");
  if (terrabake != doc.end() && terrabake->is_object()) {
    const auto scheme = terrabake->find("scheme");
    if (scheme != terrabake->end() && scheme->is_string()) {
      summary.scheme = choiceOf<SchemeKind>(scheme->get<std::string>());
    }
    const auto tile_size = terrabake->find("tile_size");
    if (tile_size != terrabake->end() && tile_size->is_number_integer()) summary.tile_size = tile_size->get<int>();
  }
  return summary;
}

std::string servedTileJson(const std::string& text, const std::string& layer_url) {
  Json doc = parseObject(text);
  const auto tiles = doc.find("tiles");
  if (tiles != doc.end() && tiles->is_array()) {
    for (Json& url : *tiles) {
      if (url.is_string()) url = resolve(url.get<std::string>(), layer_url);
    }
  }
  const auto terrabake = doc.find("terrabake");
  if (terrabake != doc.end() && terrabake->is_object()) {
    resolveKey(*terrabake, "mesh", layer_url);
    const auto elevation = terrabake->find("elevation");
    if (elevation != terrabake->end() && elevation->is_object()) {
      resolveKey(*elevation, "tiles", layer_url);
      resolveKey(*elevation, "tilejson", layer_url);
    }
    resolveKey(*terrabake, "tileset", layer_url);
    const auto sources = terrabake->find("sources");
    if (sources != terrabake->end() && sources->is_array()) {
      for (Json& source : *sources) {
        if (!source.is_string()) continue;
        const std::string path = source.get<std::string>();
        const std::size_t slash = path.find_last_of("/\\");
        source = slash == std::string::npos ? path : path.substr(slash + 1);
      }
    } else if (sources != terrabake->end()) {
      terrabake->erase(sources);  // not what terrabake writes: nothing of it is passed on
    }
  }
  return doc.dump(2) + "\n";
}

}  // namespace terrabake::io

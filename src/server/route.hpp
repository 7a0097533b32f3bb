#pragma once
// What a request path asks for. Pure text work, done before anything touches
// the disk: a path that climbs (`..`), has empty or odd segments, or does not
// fit a route is refused here.
#include <string>
#include <vector>

#include "core/types.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

struct Route {
  enum class Kind {
    kViewerPage,  // /
    kLayerList,   // /layers.json
    kHealth,      // /health
    kViewerFile,  // /viewer/<file>
    kVendorFile,  // /vendor/<package>/<file>: three, cesium, 3d-tiles-renderer, maplibre-gl
    kTileJson,    // /<layer>/tilejson.json
    kElevationTileJson,  // /<layer>/elevation.json
    kTile,        // /<layer>/<z>/<x>/<y>.<png|glb|hires.glb|elevation.png>
    kTileset,     // /<layer>/tileset.json, /<layer>/tilesets/<z>/<x>/<y>.json
    kArchive,     // /<layer>/<file>.pmtiles: an archive the layer is stored in
    kBadRequest,  // 400
    kNotFound,    // 404
  };
  Kind kind = Kind::kNotFound;
  std::string layer;  // kTileJson, kElevationTileJson, kTile, kTileset, kArchive
  TileId tile;        // kTile
  io::TileFormat format = io::TileFormat::kPng;
  std::string package;  // kVendorFile: one of vendorPackages()
  std::string file;     // kViewerFile, kVendorFile, kTileset, kArchive: relative to the folder, segments checked
  std::string problem;  // kBadRequest, kNotFound: what is wrong, for the response body
};

// `path` is the request path, percent-decoded, without the query.
Route parseRoute(const std::string& path);

// The npm packages of the viewer served under /vendor/<package>/, each with
// the folder under the viewer's node_modules its files come from: three.js
// whole (examples included), CesiumJS's built bundle, 3d-tiles-renderer's build,
// MapLibre GL JS's dist (its module and the worker module it loads beside it).
struct VendorPackage {
  const char* name;
  const char* folder;
};
const std::vector<VendorPackage>& vendorPackages();

// Names the server's own routes take, so no layer can be called that.
bool isReservedName(const std::string& name);

}  // namespace terrabake::server

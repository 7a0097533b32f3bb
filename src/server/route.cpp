#include "server/route.hpp"

#include <algorithm>
#include <array>
#include <optional>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "core/layer_name.hpp"
#include "core/text.hpp"
#include "io/tileset.hpp"

namespace terrabake::server {
namespace {

constexpr std::array<const char*, 4> kReservedNames = {"health", "layers.json", "vendor", "viewer"};

Route bad(std::string problem) {
  Route route;
  route.kind = Route::Kind::kBadRequest;
  route.problem = std::move(problem);
  return route;
}

Route notFound(std::string problem) {
  Route route;
  route.kind = Route::Kind::kNotFound;
  route.problem = std::move(problem);
  return route;
}

Route simple(Route::Kind kind) {
  Route route;
  route.kind = kind;
  return route;
}

// Empty (from "//" or a trailing "/"), "." and ".." segments never name a
// file; control characters and backslashes never appear in our file names.
bool isSafeSegment(const std::string& segment) {
  if (segment.empty() || segment == "." || segment == "..") return false;
  return std::none_of(segment.begin(), segment.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 || u == 0x7f || c == '\\';
  });
}

// One spelling per tile: tileNumber's.
bool parseNumber(const std::string& text, int& value) {
  const std::optional<int> number = tileNumber(text);
  if (number) value = *number;
  return number.has_value();
}

std::string join(std::vector<std::string>::const_iterator first, std::vector<std::string>::const_iterator last) {
  std::string text;
  for (auto it = first; it != last; ++it) text += (it == first ? "" : "/") + *it;
  return text;
}

Route parseTile(const std::vector<std::string>& parts) {
  static const char* kShape = "a tile is /<layer>/<z>/<x>/<y>.<png|glb|hires.glb|elevation.png>";
  if (parts.size() != 4) return bad(kShape);
  Route route;
  route.kind = Route::Kind::kTile;
  route.layer = parts[0];
  const std::string& last = parts[3];
  const std::size_t dot = last.find('.');
  const std::string y_text = last.substr(0, dot);
  const std::string extension = dot == std::string::npos ? "" : last.substr(dot + 1);
  const std::optional<io::TileFormat> format = io::formatOfExtension(extension);
  if (!format) return bad("unknown tile extension '" + extension + "'; " + kShape);
  route.format = *format;
  if (!parseNumber(parts[1], route.tile.z) || !parseNumber(parts[2], route.tile.x) ||
      !parseNumber(y_text, route.tile.y)) {
    return bad("z, x and y must be whole numbers without sign or leading zeros; " + std::string(kShape));
  }
  if (route.tile.z > kMaxZoom) return bad("zoom " + parts[1] + " is above " + std::to_string(kMaxZoom));
  return route;
}

// /<layer>/tilesets/<z>/<x>/<y>.json: an external tileset (io::externalTilesetPath).
Route parseExternalTileset(const std::vector<std::string>& parts) {
  static const char* kShape = "an external tileset is /<layer>/tilesets/<z>/<x>/<y>.json";
  const std::string& last = parts[4];
  const std::size_t dot = last.find('.');
  TileId tile;
  if (dot == std::string::npos || last.substr(dot) != ".json" || !parseNumber(parts[2], tile.z) ||
      !parseNumber(parts[3], tile.x) || !parseNumber(last.substr(0, dot), tile.y) || tile.z > kMaxZoom) {
    return bad(kShape);
  }
  Route route = simple(Route::Kind::kTileset);
  route.layer = parts[0];
  route.file = io::externalTilesetPath(tile);
  return route;
}

}  // namespace

Route parseRoute(const std::string& path) {
  if (path.empty() || path.front() != '/') return bad("the path must start with '/'");
  if (path == "/") return simple(Route::Kind::kViewerPage);

  std::vector<std::string> parts;
  for (std::size_t start = 1;;) {
    const std::size_t slash = path.find('/', start);
    parts.push_back(path.substr(start, slash == std::string::npos ? std::string::npos : slash - start));
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  if (!std::all_of(parts.begin(), parts.end(), isSafeSegment)) {
    return bad("empty, '.' or '..' path segments, control characters and backslashes are not allowed");
  }

  const std::string& first = parts[0];
  if (parts.size() == 1 && first == "health") return simple(Route::Kind::kHealth);
  if (parts.size() == 1 && first == "layers.json") return simple(Route::Kind::kLayerList);
  if (first == "viewer" && parts.size() >= 2) {
    Route route = simple(Route::Kind::kViewerFile);
    route.file = join(parts.begin() + 1, parts.end());
    return route;
  }
  if (first == "vendor" && parts.size() >= 3) {
    for (const VendorPackage& package : vendorPackages()) {
      if (parts[1] != package.name) continue;
      Route route = simple(Route::Kind::kVendorFile);
      route.package = package.name;
      route.file = join(parts.begin() + 2, parts.end());
      return route;
    }
  }
  if (isReservedName(first)) return notFound("no such file");
  if (!isLayerName(first)) {
    return bad("'" + shortened(first) + "' is not a layer name (at most " + std::to_string(kMaxLayerNameBytes) +
               " letters, digits, '.', '_', '-')");
  }
  if (parts.size() == 1) return notFound("no such file; try /" + first + "/tilejson.json");
  if (parts.size() == 2) {
    if (parts[1] == io::kTilesetFile) {
      Route route = simple(Route::Kind::kTileset);
      route.layer = first;
      route.file = io::kTilesetFile;
      return route;
    }
    const std::string_view extension(io::kPmtilesExtension);
    if (parts[1].size() > extension.size() && endsWith(parts[1], extension)) {
      Route route = simple(Route::Kind::kArchive);
      route.layer = first;
      route.file = parts[1];
      return route;
    }
    Route route;
    if (parts[1] == io::kTileJsonFile) {
      route = simple(Route::Kind::kTileJson);
    } else if (parts[1] == io::kElevationTileJsonFile) {
      route = simple(Route::Kind::kElevationTileJson);
    } else {
      return notFound("no such file");
    }
    route.layer = first;
    return route;
  }
  if (parts.size() == 5 && parts[1] == "tilesets") return parseExternalTileset(parts);
  return parseTile(parts);
}

const std::vector<VendorPackage>& vendorPackages() {
  static const std::vector<VendorPackage> kPackages = {
      {"three", "three"},
      {"cesium", "cesium/Build/Cesium"},
      {"3d-tiles-renderer", "3d-tiles-renderer/build"},
      {"maplibre-gl", "maplibre-gl/dist"}};
  return kPackages;
}

bool isReservedName(const std::string& name) {
  return std::find(kReservedNames.begin(), kReservedNames.end(), name) != kReservedNames.end();
}

}  // namespace terrabake::server

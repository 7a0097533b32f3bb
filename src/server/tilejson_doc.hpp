#pragma once
// What the server reads from a layer's tilejson.json, and the document with
// absolute URLs for one request (relative URLs would resolve against the
// viewer page, not the tilejson, in many clients).
#include <array>
#include <string>

namespace terrabake::server {

struct TileJsonSummary {
  int min_zoom = 0;
  int max_zoom = 0;
  std::array<double, 4> bounds_deg{};  // west, south, east, north
  std::string scheme;                  // terrabake.scheme; "" when the file has none
};

// Throws std::runtime_error saying what is missing or malformed.
TileJsonSummary summarizeTileJson(const std::string& text);

// `text` with each relative URL in "tiles" and "terrabake.mesh" resolved
// against `layer_url` ("http://host:port/<layer>/"); other URLs stay as they are.
std::string withAbsoluteUrls(const std::string& text, const std::string& layer_url);

}  // namespace terrabake::server

#include "server/tilejson_doc.hpp"

#include <stdexcept>

#include <nlohmann/json.hpp>

namespace terrabake::server {
namespace {

using Json = nlohmann::ordered_json;  // keeps the key order the file was written in

Json parse(const std::string& text) {
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

}  // namespace

TileJsonSummary summarizeTileJson(const std::string& text) {
  const Json doc = parse(text);
  TileJsonSummary summary;
  try {
    summary.min_zoom = doc.at("minzoom").get<int>();
    summary.max_zoom = doc.at("maxzoom").get<int>();
    summary.bounds_deg = doc.at("bounds").get<std::array<double, 4>>();
  } catch (const Json::exception& e) {
    throw std::runtime_error(std::string("minzoom, maxzoom or bounds: ") + e.what());
  }
  const auto terrabake = doc.find("terrabake");
  if (terrabake != doc.end() && terrabake->is_object()) {
    const auto scheme = terrabake->find("scheme");
    if (scheme != terrabake->end() && scheme->is_string()) summary.scheme = scheme->get<std::string>();
  }
  return summary;
}

std::string withAbsoluteUrls(const std::string& text, const std::string& layer_url) {
  Json doc = parse(text);
  const auto tiles = doc.find("tiles");
  if (tiles != doc.end() && tiles->is_array()) {
    for (Json& url : *tiles) {
      if (url.is_string()) url = resolve(url.get<std::string>(), layer_url);
    }
  }
  const auto terrabake = doc.find("terrabake");
  if (terrabake != doc.end() && terrabake->is_object()) {
    const auto mesh = terrabake->find("mesh");
    if (mesh != terrabake->end() && mesh->is_string()) *mesh = resolve(mesh->get<std::string>(), layer_url);
  }
  return doc.dump(2) + "\n";
}

}  // namespace terrabake::server

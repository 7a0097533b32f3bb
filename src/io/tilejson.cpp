#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "io/tile_files.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;

// Middle longitude of [west, east], also when the bounds cross the antimeridian
// (west > east).
double middleLongitude(double west, double east) {
  if (west > east) east += 360;
  double mid = (west + east) / 2;
  if (mid >= 180) mid -= 360;
  return mid;
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

  const Json doc = {
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
       {{"version", "1"},
        {"scheme", info.scheme},
        {"tile_size", info.tile_size},
        {"bits", info.bits},
        {"green", info.green_up ? "up" : "down"},
        {"alpha", info.alpha},
        {"z_scale", info.z_scale},
        {"exaggeration", info.exaggeration},
        {"mesh", "./{z}/{x}/{y}.glb"},
        {"low_poly", {{"grid", info.low_poly_grid}}},
        {"sources", info.sources}}},
  };
  return doc.dump(2) + "\n";
}

}  // namespace terrabake::io

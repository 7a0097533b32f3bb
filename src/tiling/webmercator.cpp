#include <cmath>

#include "tiling/scheme.hpp"

namespace terrabake::tiling {
namespace {

constexpr double kEarthRadiusM = 6378137.0;  // the sphere of EPSG:3857
// Half the width of the EPSG:3857 square: pi * 6378137 m.
constexpr double kHalfWorldM = 20037508.342789244;
// The latitude where the square ends: atan(sinh(pi)).
constexpr double kMaxLatDeg = 85.0511287798066;
constexpr double kDegToRad = M_PI / 180.0;

class WebMercator : public Scheme {
 public:
  using Scheme::Scheme;
  SchemeKind kind() const override { return SchemeKind::kWebMercator; }
  std::string crs() const override { return "EPSG:3857"; }
  bool tmsRows() const override { return false; }
  int maxZoom() const override { return kMaxZoom; }

  LevelGrid levelGrid(int zoom) const override {
    const int tiles = 1 << zoom;
    const double size = 2 * kHalfWorldM / tiles;
    return {-kHalfWorldM, kHalfWorldM, size, size, tiles, tiles};
  }

  double maxLatDeg() const override { return kMaxLatDeg; }

  // Spherical Mercator keeps east-west and north-south apart, so a box maps to a box.
  std::optional<Extent> fromLonLat(const Extent& lon_lat) const override {
    const auto x = [](double lon_deg) { return kEarthRadiusM * lon_deg * kDegToRad; };
    const auto y = [](double lat_deg) {
      return kEarthRadiusM * std::log(std::tan(M_PI / 4 + lat_deg * kDegToRad / 2));
    };
    return Extent{x(lon_lat.min_x), y(lon_lat.min_y), x(lon_lat.max_x), y(lon_lat.max_y)};
  }
};

}  // namespace

std::unique_ptr<Scheme> makeWebMercator(int tile_size) { return std::make_unique<WebMercator>(tile_size); }

}  // namespace terrabake::tiling

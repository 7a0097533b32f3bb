#include "tiling/scheme.hpp"

namespace terrabake::tiling {
namespace {

// Cesium's geographic grid: two 180-degree tiles at zoom 0, rows counted from
// the south (TMS).
class Geodetic : public Scheme {
 public:
  using Scheme::Scheme;
  SchemeKind kind() const override { return SchemeKind::kGeodetic; }
  std::string crs() const override { return "EPSG:4326"; }
  bool tmsRows() const override { return true; }
  int maxZoom() const override { return kMaxZoom; }

  LevelGrid levelGrid(int zoom) const override {
    const int rows = 1 << zoom;
    const double size_deg = 180.0 / rows;
    return {-180.0, 90.0, size_deg, size_deg, 2 * rows, rows};
  }

  std::optional<Extent> fromLonLat(const Extent& lon_lat) const override { return lon_lat; }
};

}  // namespace

std::unique_ptr<Scheme> makeGeodetic(int tile_size) { return std::make_unique<Geodetic>(tile_size); }

}  // namespace terrabake::tiling

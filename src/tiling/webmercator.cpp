#include "tiling/scheme.hpp"

namespace terrabake::tiling {
namespace {

// Half the width of the EPSG:3857 square: pi * 6378137 m.
constexpr double kHalfWorldM = 20037508.342789244;
constexpr int kMaxZoom = 24;

class WebMercator : public Scheme {
 public:
  std::string name() const override { return "webmercator"; }
  std::string crs() const override { return "EPSG:3857"; }
  bool tmsRows() const override { return false; }
  int maxZoom() const override { return kMaxZoom; }

  LevelGrid levelGrid(int zoom) const override {
    const int tiles = 1 << zoom;
    const double size = 2 * kHalfWorldM / tiles;
    return {-kHalfWorldM, kHalfWorldM, size, size, tiles, tiles};
  }
};

}  // namespace

std::unique_ptr<Scheme> makeWebMercator() { return std::make_unique<WebMercator>(); }

}  // namespace terrabake::tiling

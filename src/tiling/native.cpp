#include <algorithm>
#include <cmath>

#include "tiling/scheme.hpp"

namespace terrabake::tiling {
namespace {

class Native : public Scheme {
 public:
  Native(const GridSpec& dem, int tile_size) : Scheme(tile_size), m_dem(dem) {
    // Level 0 must hold the whole DEM in one tile.
    const double pixels = std::max(dem.width, dem.height);
    m_levels = 1 + std::max(0, int(std::ceil(std::log2(pixels / tile_size) - 1e-9)));
  }

  SchemeKind kind() const override { return SchemeKind::kNative; }
  std::string crs() const override { return m_dem.crs; }
  bool tmsRows() const override { return false; }
  int maxZoom() const override { return m_levels - 1; }
  std::optional<Extent> fromLonLat(const Extent&) const override { return std::nullopt; }

  LevelGrid levelGrid(int level) const override {
    const double pixels = tileSize() * std::ldexp(1.0, m_levels - 1 - level);
    return {m_dem.origin_x, m_dem.origin_y, pixels * m_dem.cell_w, pixels * m_dem.cell_h,
            int(std::ceil(m_dem.width / pixels)), int(std::ceil(m_dem.height / pixels))};
  }

 private:
  GridSpec m_dem;
  int m_levels;
};

}  // namespace

std::unique_ptr<Scheme> makeNative(const GridSpec& dem_grid, int tile_size) {
  return std::make_unique<Native>(dem_grid, tile_size);
}

}  // namespace terrabake::tiling

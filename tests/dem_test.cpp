// DEM reads and hole filling.
#include <gtest/gtest.h>

#include <cmath>

#include "dem/dem_source.hpp"
#include "dem/fill_holes.hpp"
#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"
#include "tiling/scheme.hpp"

namespace terrabake {
namespace {

TEST(FillHoles, LeavesNoHoleAndNoSpike) {
  // A plane with a 20 x 20 hole: the fill must stay within the values around
  // it (no spikes) and be smooth (no walls at the hole's edge).
  Raster<float> r(64, 64);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) r.at(x, y) = (x >= 20 && x < 40 && y >= 20 && y < 40) ? NAN : float(x + 2 * y);
  }
  ASSERT_TRUE(dem::fillHoles(r));
  float worst_step = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      ASSERT_FALSE(std::isnan(r.at(x, y)));
      EXPECT_GE(r.at(x, y), 0.0f);
      EXPECT_LE(r.at(x, y), 63.0f + 126.0f);
      if (x > 0) worst_step = std::max(worst_step, std::abs(r.at(x, y) - r.at(x - 1, y)));
    }
  }
  // The plane climbs 1 a column; inside the hole a step may grow but stays
  // far from a wall.
  EXPECT_LE(worst_step, 4.0f);
}

TEST(FillHoles, RefusesAWindowWithoutData) {
  Raster<float> r(8, 8, NAN);
  EXPECT_FALSE(dem::fillHoles(r));
}

TEST(DemSource, ReadsItsOwnGridExactly) {
  const auto path = test::sharedFixture("analytic_utm33_64.tif", [](const auto& p) {
    test_support::writeUtmDem(p, 15.3, 60.0, 30.0, 64, 64);
  });
  const dem::DemSource dem(path.string());
  const GridSpec& g = dem.info().grid;
  EXPECT_EQ(g.width, 64);
  EXPECT_DOUBLE_EQ(g.cell_w, 30.0);
  // Native full resolution: cubic sampling at pixel centres returns the
  // pixels themselves.
  const auto native = tiling::makeNative(g, 32);
  const GridSpec window = native->texelGrid({1, 0, 0}, 32, 2);
  const Raster<float> h = dem.read(window, dem.planFor(window));
  EXPECT_TRUE(std::isnan(h.at(0, 0)));  // beyond the DEM's north-west corner
  const double e = g.origin_x + 5.5 * 30, n = g.origin_y - 7.5 * 30;
  EXPECT_NEAR(h.at(2 + 5, 2 + 7), test_support::heightUtm(e, n), 1e-3);
}

}  // namespace
}  // namespace terrabake

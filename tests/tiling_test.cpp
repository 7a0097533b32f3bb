// Tiling schemes against docs/CONTRACT.md §2, and texel grids against §3.
#include <gtest/gtest.h>

#include "tiling/scheme.hpp"

namespace terrabake {
namespace {

constexpr double kHalfWorldM = 20037508.342789244;

TEST(WebMercator, ZoomZeroIsTheWholeSquareAndRowsRunSouth) {
  const auto s = tiling::makeWebMercator();
  const Extent e = s->tileExtent({0, 0, 0});
  EXPECT_DOUBLE_EQ(e.min_x, -kHalfWorldM);
  EXPECT_DOUBLE_EQ(e.max_y, kHalfWorldM);
  const Extent north_west = s->tileExtent({1, 0, 0});
  EXPECT_DOUBLE_EQ(north_west.max_y, kHalfWorldM);  // y = 0 is the north edge
  EXPECT_DOUBLE_EQ(north_west.min_y, 0.0);
  EXPECT_FALSE(s->tmsRows());
}

TEST(WebMercator, NeighboursShareEdgesExactly) {
  const auto s = tiling::makeWebMercator();
  EXPECT_EQ(s->tileExtent({12, 2161, 1447}).max_x, s->tileExtent({12, 2162, 1447}).min_x);
  EXPECT_EQ(s->tileExtent({12, 2161, 1447}).min_y, s->tileExtent({12, 2161, 1448}).max_y);
}

TEST(WebMercator, CoveringListsOverlappingTilesRowMajor) {
  const auto s = tiling::makeWebMercator();
  const auto tiles = s->tilesCovering({-1, -1, 1, 1}, 1);
  ASSERT_EQ(tiles.size(), 4u);
  EXPECT_EQ(tiles[0], (TileId{1, 0, 0}));
  EXPECT_EQ(tiles[1], (TileId{1, 1, 0}));
  EXPECT_EQ(tiles[3], (TileId{1, 1, 1}));
}

TEST(Geodetic, TwoRootTilesAndTmsRows) {
  const auto s = tiling::makeGeodetic();
  EXPECT_TRUE(s->tmsRows());
  const Extent west = s->tileExtent({0, 0, 0}), east = s->tileExtent({0, 1, 0});
  EXPECT_DOUBLE_EQ(west.min_x, -180);
  EXPECT_DOUBLE_EQ(west.max_x, 0);
  EXPECT_DOUBLE_EQ(east.max_x, 180);
  EXPECT_DOUBLE_EQ(west.min_y, -90);
  EXPECT_DOUBLE_EQ(west.max_y, 90);
  // y = 0 is the south edge.
  EXPECT_DOUBLE_EQ(s->tileExtent({1, 0, 0}).min_y, -90);
  EXPECT_DOUBLE_EQ(s->tileExtent({1, 0, 1}).max_y, 90);
  EXPECT_EQ(s->tilesCovering({10, 40, 11, 41}, 1), (std::vector<TileId>{{1, 2, 1}}));
}

TEST(Native, LevelsHalveFromFullResolution) {
  GridSpec dem;
  dem.crs = "EPSG:32632";
  dem.origin_x = 1000;
  dem.origin_y = 9000;
  dem.cell_w = dem.cell_h = 30;
  dem.width = 1000;
  dem.height = 600;
  const auto s = tiling::makeNative(dem, 256);
  EXPECT_EQ(s->maxZoom(), 2);  // 256, 512, 1024 pixels a tile
  const Extent full = s->tileExtent({2, 1, 0});
  EXPECT_DOUBLE_EQ(full.min_x, 1000 + 256 * 30);
  EXPECT_DOUBLE_EQ(full.max_y, 9000);
  EXPECT_EQ(s->tilesCovering({-1e9, -1e9, 1e9, 1e9}, 2).size(), 4u * 3u);
  EXPECT_EQ(s->tilesCovering({-1e9, -1e9, 1e9, 1e9}, 0).size(), 1u);
}

TEST(TexelGrid, CentresAtHalfTexelsWithApron) {
  const auto s = tiling::makeWebMercator();
  const GridSpec g = s->texelGrid({0, 0, 0}, 256, 3);
  const double texel = 2 * kHalfWorldM / 256;
  EXPECT_EQ(g.width, 262);
  // Texel (0, 0) is cell (3, 3); its centre is half a texel in from the corner.
  EXPECT_NEAR(g.centreX(3), -kHalfWorldM + 0.5 * texel, 1e-6);
  EXPECT_NEAR(g.centreY(3), kHalfWorldM - 0.5 * texel, 1e-6);
}

TEST(Paths, FollowTheLayerTemplate) {
  EXPECT_EQ(tiling::tilePath("tiles/sample", {12, 2161, 1447}, "png"), "tiles/sample/12/2161/1447.png");
}

}  // namespace
}  // namespace terrabake

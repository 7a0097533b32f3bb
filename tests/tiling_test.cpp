// Tiling schemes against docs/CONTRACT.md §2, texel grids against §3, and
// the tile ranges a job plans over its areas.
#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <vector>

#include "core/extent_groups.hpp"
#include "tiling/scheme.hpp"

namespace terrabake {
namespace {

constexpr double kHalfWorldM = 20037508.342789244;

TEST(WebMercator, ZoomZeroIsTheWholeSquareAndRowsRunSouth) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const Extent e = s->tileExtent({0, 0, 0});
  EXPECT_DOUBLE_EQ(e.min_x, -kHalfWorldM);
  EXPECT_DOUBLE_EQ(e.max_y, kHalfWorldM);
  const Extent north_west = s->tileExtent({1, 0, 0});
  EXPECT_DOUBLE_EQ(north_west.max_y, kHalfWorldM);  // y = 0 is the north edge
  EXPECT_DOUBLE_EQ(north_west.min_y, 0.0);
  EXPECT_FALSE(s->tmsRows());
}

TEST(WebMercator, NeighboursShareEdgesExactly) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  EXPECT_EQ(s->tileExtent({12, 2161, 1447}).max_x, s->tileExtent({12, 2162, 1447}).min_x);
  EXPECT_EQ(s->tileExtent({12, 2161, 1447}).min_y, s->tileExtent({12, 2161, 1448}).max_y);
}

TEST(WebMercator, CoveringListsOverlappingTilesRowMajor) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const auto tiles = s->tilesCovering({-1, -1, 1, 1}, 1);
  ASSERT_EQ(tiles.size(), 4u);
  EXPECT_EQ(tiles[0], (TileId{1, 0, 0}));
  EXPECT_EQ(tiles[1], (TileId{1, 1, 0}));
  EXPECT_EQ(tiles[3], (TileId{1, 1, 1}));
}

TEST(Geodetic, TwoRootTilesAndTmsRows) {
  const auto s = tiling::makeScheme(SchemeKind::kGeodetic, 256);
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
  const auto s = tiling::makeScheme(SchemeKind::kNative, 256, &dem);
  EXPECT_EQ(s->maxZoom(), 2);  // 256, 512, 1024 pixels a tile
  const Extent full = s->tileExtent({2, 1, 0});
  EXPECT_DOUBLE_EQ(full.min_x, 1000 + 256 * 30);
  EXPECT_DOUBLE_EQ(full.max_y, 9000);
  EXPECT_EQ(s->tilesCovering({-1e9, -1e9, 1e9, 1e9}, 2).size(), 4u * 3u);
  EXPECT_EQ(s->tilesCovering({-1e9, -1e9, 1e9, 1e9}, 0).size(), 1u);
}

TEST(TexelGrid, CentresAtHalfTexelsWithApron) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const GridSpec g = s->texelGrid({0, 0, 0}, 3);
  const double texel = 2 * kHalfWorldM / 256;
  EXPECT_EQ(g.width, 262);
  // Texel (0, 0) is cell (3, 3); its centre is half a texel in from the corner.
  EXPECT_NEAR(g.centreX(3), -kHalfWorldM + 0.5 * texel, 1e-6);
  EXPECT_NEAR(g.centreY(3), kHalfWorldM - 0.5 * texel, 1e-6);
}

TEST(WebMercator, LonLatBoxesMapToTheSquareAndStopShortOfThePoles) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const Extent world = *s->fromLonLat({-180, -s->maxLatDeg(), 180, s->maxLatDeg()});
  // Longitudes map linearly, to a double's rounding of 20,000 km. Near 85°
  // Mercator stretches any error in latitude (the largest written to 13
  // decimals, the projection's arithmetic) twelve times: 1 mm holds it.
  constexpr double kLinearM = 1e-6, kMaxLatitudeM = 1e-3;
  EXPECT_NEAR(world.min_x, -kHalfWorldM, kLinearM);
  EXPECT_NEAR(world.max_x, kHalfWorldM, kLinearM);
  EXPECT_NEAR(world.min_y, -kHalfWorldM, kMaxLatitudeM);
  EXPECT_NEAR(world.max_y, kHalfWorldM, kMaxLatitudeM);
}

TEST(Schemes, CoversAgreesWithTilesCovering) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const Extent area = *s->fromLonLat({9.8, 46.36, 10.2, 46.64});
  for (int z = 8; z <= 12; ++z) {
    const std::vector<TileId> listed = s->tilesCovering(area, z);
    for (const TileId& tile : listed) EXPECT_TRUE(s->covers(area, tile)) << tile.str();
    const TileId first = listed.front(), last = listed.back();
    EXPECT_FALSE(s->covers(area, {z, first.x - 1, first.y})) << "west of " << first.str();
    EXPECT_FALSE(s->covers(area, {z, last.x, last.y + 1})) << "south of " << last.str();
  }
  EXPECT_FALSE(s->covers(area, {kMaxZoom + 1, 0, 0}));
}

TEST(Schemes, RangesCountAndIndexTheTilesWithoutListingThem) {
  for (const SchemeKind kind : {SchemeKind::kWebMercator, SchemeKind::kGeodetic}) {
    const auto s = tiling::makeScheme(kind, 256);
    const auto area = s->fromLonLat({9.8, 45.9, 10.7, 46.6});
    ASSERT_TRUE(area);
    for (int z = 6; z <= 12; ++z) {
      const std::vector<TileId> listed = s->tilesCovering(*area, z);
      const tiling::TileRange range = s->rangeCovering(*area, z);
      ASSERT_EQ(range.count(), listed.size());
      for (std::size_t i = 0; i < listed.size(); ++i) EXPECT_EQ(s->tileAt(range, i), listed[i]);
    }
  }
  // A whole world at zoom 24: counted, not listed.
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const tiling::TileRange world = s->rangeCovering({-2.1e7, -2.1e7, 2.1e7, 2.1e7}, 24);
  EXPECT_EQ(world.count(), std::uint64_t(1) << 48);
  EXPECT_EQ(s->tileAt(world, world.count() - 1), (TileId{24, (1 << 24) - 1, (1 << 24) - 1}));
}

TEST(ExtentGroups, BoxesThatMeetMergeAndFarApartOnesStayApart) {
  // A row of three touching boxes, one far away, and one that only the
  // first group's box reaches (no member of the group does).
  const std::vector<Extent> boxes = {{2, 0, 3, 1}, {100, 100, 101, 101}, {0, 0, 1, 1}, {1, 0, 2, 1}, {2.5, 1.5, 4, 3}};
  const std::vector<Extent> merged = mergeMeeting(boxes);
  ASSERT_EQ(merged.size(), 3u);
  // North first: the far box, then the row (corner to corner with the last box).
  EXPECT_EQ(merged[0].min_x, 100);
  EXPECT_EQ(merged[1].min_x, 2.5);
  EXPECT_EQ(merged[2].min_x, 0);
  EXPECT_EQ(merged[2].max_x, 3);
  // Growing a group's box until it meets another merges them in a later round.
  // (an L of a tall and a wide box, and a box in the corner between their arms).
  const std::vector<Extent> reached = mergeMeeting({{2, 2, 2.5, 2.5}, {0, 0, 1, 3}, {0.5, 0, 3, 0.5}});
  ASSERT_EQ(reached.size(), 1u);
  EXPECT_EQ(reached[0].max_x, 3);
  EXPECT_EQ(reached[0].max_y, 3);
  EXPECT_EQ(mergeMeeting({}).size(), 0u);
  // Thousands of areas in the same tile at a coarse zoom (a VRT's scattered
  // sources) are one group, and a far tile another.
  std::vector<Extent> repeated(20000, Extent{0, 0, 1, 1});
  repeated.push_back({5, 5, 6, 6});
  const std::vector<Extent> two = mergeMeeting(repeated);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[1].max_x, 1);
}

TEST(Schemes, RangesOverSeveralAreasHoldEachTileOnce) {
  const auto s = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  const Extent alps = *s->fromLonLat({9.8, 46.36, 10.2, 46.64});
  const Extent overlapping = *s->fromLonLat({10.1, 46.3, 10.5, 46.5});
  const Extent fiji = *s->fromLonLat({178.0, -17.2, 178.2, -17.0});
  for (int z = 0; z <= 14; ++z) {
    std::set<TileId> wanted;
    for (const Extent& area : {alps, overlapping, fiji}) {
      for (const TileId& tile : s->tilesCovering(area, z)) wanted.insert(tile);
    }
    const std::vector<tiling::TileRange> ranges = s->rangesCovering({alps, overlapping, fiji}, z);
    std::set<TileId> listed;
    std::uint64_t count = 0;
    for (const tiling::TileRange& range : ranges) {
      count += range.count();
      for (std::uint64_t i = 0; i < range.count(); ++i) listed.insert(s->tileAt(range, i));
    }
    EXPECT_EQ(listed.size(), count) << "a tile listed twice at zoom " << z;
    for (const TileId& tile : wanted) EXPECT_EQ(listed.count(tile), 1u) << tile.str();
    // Far apart at deep zooms: the Alps' two areas as one range, Fiji's
    // apart, and nothing between them.
    if (z >= 6) {
      ASSERT_EQ(ranges.size(), 2u) << z;
      EXPECT_EQ(count, s->rangeCovering(alps.united(overlapping), z).count() + s->rangeCovering(fiji, z).count()) << z;
    }
  }
  EXPECT_EQ(s->rangesCovering({alps, fiji}, 0).size(), 1u);
}

TEST(Schemes, NativeNeedsTheDemGrid) {
  EXPECT_THROW(tiling::makeScheme(SchemeKind::kNative, 256), std::invalid_argument);
  EXPECT_EQ(tiling::makeScheme(SchemeKind::kGeodetic, 512)->tileSize(), 512);
}

}  // namespace
}  // namespace terrabake

// DEM reads and hole filling.
#include <gtest/gtest.h>

#include <gdal_priv.h>

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
  const dem::DemSource dem({path.string()});
  const GridSpec& g = dem.info().grid;
  EXPECT_EQ(g.width, 64);
  EXPECT_DOUBLE_EQ(g.cell_w, 30.0);
  // Native full resolution: cubic sampling at pixel centres returns the
  // pixels themselves.
  const auto native = tiling::makeScheme(SchemeKind::kNative, 32, &g);
  const GridSpec window = native->texelGrid({1, 0, 0}, 2);
  const Raster<float> h = dem.read(window, dem.planFor(window));
  EXPECT_TRUE(std::isnan(h.at(0, 0)));  // beyond the DEM's north-west corner
  const double e = g.origin_x + 5.5 * 30, n = g.origin_y - 7.5 * 30;
  EXPECT_NEAR(h.at(2 + 5, 2 + 7), test_support::heightUtm(e, n), 1e-3);
}

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

// An Int16 DEM of the analytic terrain with SRTM void markers (-32768 and
// -32767) that the file does not declare, plus a Float32 twin with NaN and
// infinities.
std::filesystem::path demWithUndeclaredVoids(GDALDataType type) {
  const std::string name = type == GDT_Int16 ? "voids_int16.tif" : "voids_float32.tif";
  return test::sharedFixture(name, [type](const std::filesystem::path& path) {
    const auto source = test::sharedFixture("analytic_utm33_64.tif", [](const auto& p) {
      test_support::writeUtmDem(p, 15.3, 60.0, 30.0, 64, 64);
    });
    GDALAllRegister();
    std::unique_ptr<GDALDataset> in(GDALDataset::Open(source.c_str(), GDAL_OF_RASTER));
    std::unique_ptr<GDALDataset> out(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        path.c_str(), 64, 64, 1, type, nullptr));
    double gt[6];
    in->GetGeoTransform(gt);
    out->SetGeoTransform(gt);
    out->SetSpatialRef(in->GetSpatialRef());
    std::vector<float> h(64 * 64);
    ASSERT_EQ(in->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 64, 64, h.data(), 64, 64, GDT_Float32, 0, 0), CE_None);
    for (int r = 20; r < 30; ++r) {
      for (int c = 20; c < 30; ++c) {
        if (type == GDT_Int16) {
          h[r * 64 + c] = c < 25 ? -32768.0f : -32767.0f;
        } else {
          h[r * 64 + c] = c < 25 ? NAN : (r < 25 ? INFINITY : -INFINITY);
        }
      }
    }
    ASSERT_EQ(out->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 64, 64, h.data(), 64, 64, GDT_Float32, 0, 0), CE_None);
  });
}

class UndeclaredVoids : public ::testing::TestWithParam<GDALDataType> {};

TEST_P(UndeclaredVoids, BecomeHolesWithoutTouchingTheirNeighbours) {
  const dem::DemSource dem({demWithUndeclaredVoids(GetParam()).string()});
  EXPECT_FALSE(dem.info().nodata.has_value());
  // Web Mercator at 60 degrees north: every texel is interpolated from
  // several DEM pixels, so a void marker mixed in would show as a spike.
  const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, 64);
  const Extent area = dem.boundsIn(scheme->crs());
  const auto tiles = scheme->tilesCovering(area, 14);
  int holes = 0;
  for (const TileId& tile : tiles) {
    const GridSpec grid = scheme->texelGrid(tile, 2);
    const Raster<float> h = dem.read(grid, dem.planFor(grid));
    for (float v : h.data) {
      if (std::isnan(v)) {
        ++holes;
        continue;
      }
      // The analytic terrain spans 210-1490 m; cubic overshoot is metres.
      EXPECT_GT(v, 150.0f);
      EXPECT_LT(v, 1550.0f);
    }
  }
  EXPECT_GT(holes, 0);
}

INSTANTIATE_TEST_SUITE_P(Int16AndFloat32, UndeclaredVoids, ::testing::Values(GDT_Int16, GDT_Float32),
                         [](const auto& test_info) { return std::string(test_info.param == GDT_Int16 ? "int16" : "float32"); });

}  // namespace
}  // namespace terrabake

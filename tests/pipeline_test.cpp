// Whole runs through the library: holes in the DEM never reach a normal, a
// tile with no valid sample is not written, and the bytes of every tile do
// not depend on the number of workers.
#include <gtest/gtest.h>

#include <gdal_priv.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>

#include "layer_check.hpp"
#include "test_helpers.hpp"
#include "core/error.hpp"
#include "dem/dem_source.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

constexpr int kDemPixels = 128;
constexpr int kTileSize = 64;  // native: 2 x 2 tiles at full resolution

// The analytic terrain with a NaN hole in the north-west tile and the whole
// south-east tile void.
std::filesystem::path demWithHoles() {
  return test::sharedFixture("holes_128.tif", [](const std::filesystem::path& path) {
    test_support::writeUtmDem(path, 15.3, 60.0, 30.0, kDemPixels, kDemPixels);
    GDALAllRegister();
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    std::vector<float> row(kDemPixels);
    GDALRasterBand* band = ds->GetRasterBand(1);
    for (int r = 0; r < kDemPixels; ++r) {
      ASSERT_EQ(band->RasterIO(GF_Read, 0, r, kDemPixels, 1, row.data(), kDemPixels, 1, GDT_Float32, 0, 0), CE_None);
      for (int c = 0; c < kDemPixels; ++c) {
        const bool hole = c >= 20 && c < 35 && r >= 25 && r < 40;
        const bool void_tile = c >= kTileSize && r >= kTileSize;
        if (hole || void_tile) row[c] = NAN;
      }
      ASSERT_EQ(band->RasterIO(GF_Write, 0, r, kDemPixels, 1, row.data(), kDemPixels, 1, GDT_Float32, 0, 0), CE_None);
    }
  });
}

TEST(Pipeline, HolesAreFilledAndVoidTilesAreNotWritten) {
  config::TileJob job = test::tileJob(demWithHoles(), "pipeline/holes", SchemeKind::kNative, 1, 1);
  job.tile_size = kTileSize;
  const auto summary = pipeline::runTileJob(job);
  EXPECT_EQ(summary.written, 3);
  EXPECT_EQ(summary.empty, 1);
  EXPECT_EQ(summary.failed, 0);
  EXPECT_FALSE(std::filesystem::exists(test::layerDir(job) / "1/1/1.png"));
  EXPECT_FALSE(std::filesystem::exists(test::layerDir(job) / "1/1/1.glb"));

  // Every texel of the holed tile decodes to a finite normal pointing up.
  const test::DecodedTile tile = test::readTile(test::layerDir(job), {1, 0, 0});
  const glm::dvec3 up = test_support::ellipsoidUpEcef(15.3, 60.0);
  for (int j = 0; j < kTileSize; ++j) {
    for (int i = 0; i < kTileSize; ++i) {
      const auto n = tile.ecefNormal(i, j);
      ASSERT_TRUE(n && std::isfinite(n->x) && std::isfinite(n->y) && std::isfinite(n->z));
      // The terrain is never steeper than about 31 degrees; a spike or wall
      // at the hole's edge would be.
      EXPECT_LT(test::angleBetweenDeg(*n, up), 45.0) << "texel " << i << "," << j;
    }
  }
}

TEST(Pipeline, OneAndFourWorkersWriteTheSameBytes) {
  const auto dem = test::sharedFixture("analytic_utm33_256.tif", [](const auto& path) {
    test_support::writeUtmDem(path, 15.3, 60.0, 30.0, 256, 256);
  });
  config::TileJob one = test::tileJob(dem, "pipeline/workers1", SchemeKind::kWebMercator, 11, 13);
  one.tile_size = 128;
  one.workers = 1;
  config::TileJob four = one;
  four.output_dir = test::testOutput("pipeline/workers4").string();
  four.workers = 4;
  ASSERT_EQ(pipeline::runTileJob(one).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(four).failed, 0);
  const auto a = test::snapshot(test::layerDir(one)), b = test::snapshot(test::layerDir(four));
  EXPECT_GT(a.size(), 10u);
  EXPECT_TRUE(a == b) << "layers made with 1 and 4 workers differ";
}

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

namespace ts = test_support;

// A fallback DEM of the same terrain fills a void of the first one: the
// decoded normals there match the terrain (within the 8-bit accuracy bound
// of docs/CONTRACT.md §4 plus resampling from another CRS), and the edges of the
// former hole show no spike or wall.
constexpr double kMaxMergedAngleDeg = 1.0;
// Control: without the fallback, the void is interpolated and the normals
// there are visibly wrong, so the bound above can tell the two apart.
constexpr double kMinInterpolatedAngleDeg = 3.0;

constexpr double kCentreLon = 15.3, kCentreLat = 60.0;

// The analytic terrain in UTM with a 40 x 40 pixel void in the middle.
std::filesystem::path demWithVoid() {
  return test::sharedFixture("void_utm33_128.tif", [](const std::filesystem::path& path) {
    ts::writeUtmDem(path, kCentreLon, kCentreLat, 30.0, 128, 128);
    GDALAllRegister();
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    const std::vector<float> voids(40 * 40, NAN);
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 44, 44, 40, 40, const_cast<float*>(voids.data()), 40, 40,
                                             GDT_Float32, 0, 0),
              CE_None);
  });
}

// The same terrain in EPSG:4326 over the middle of the first DEM, so the
// layer keeps the first DEM's grid.
std::filesystem::path geographicFallback() {
  return test::sharedFixture("fallback_epsg4326.tif", [](const std::filesystem::path& path) {
    const double lat_deg = 30.0 / 111320.0;
    ts::writeGeographicDem(path, kCentreLon, kCentreLat, 2 * lat_deg, lat_deg, 70, 70);
  });
}

// Worst angle between decoded and true normals over the texels of the void.
double worstAngleInVoidDeg(const std::vector<std::string>& dems, const std::string& name) {
  config::TileJob job = test::tileJob(dems.front(), "pipeline/" + name, SchemeKind::kNative, 1, 1);
  job.dems = dems;
  job.tile_size = 64;
  EXPECT_EQ(pipeline::runTileJob(job).failed, 0);
  const test::DemGeometry geometry(dems.front());
  double worst = 0;
  for (int ty = 0; ty < 2; ++ty) {
    for (int tx = 0; tx < 2; ++tx) {
      const test::DecodedTile tile = test::readTile(test::layerDir(job), {1, tx, ty});
      for (int j = 0; j < 64; ++j) {
        for (int i = 0; i < 64; ++i) {
          const double col = tx * 64 + i + 0.5, row = ty * 64 + j + 0.5;
          // The void and a ring of 6 pixels around it: where walls would show.
          if (col < 38 || col > 90 || row < 38 || row > 90) continue;
          const glm::dvec2 lon_lat = geometry.lonLatOfPixel(col, row);
          worst = std::max(worst, test::angleBetweenDeg(*tile.ecefNormal(i, j), ts::normalEcef(lon_lat.x, lon_lat.y)));
        }
      }
    }
  }
  return worst;
}

TEST(Pipeline, FallbackDemFillsTheVoidsOfTheFirst) {
  const std::string first = demWithVoid().string(), fallback = geographicFallback().string();
  const double merged = worstAngleInVoidDeg({first, fallback}, "merged");
  const double alone = worstAngleInVoidDeg({first}, "alone");
  std::printf("worst angle over the void: %.3f deg merged, %.3f deg interpolated alone\n", merged, alone);
  EXPECT_LE(merged, kMaxMergedAngleDeg);
  EXPECT_GE(alone, kMinInterpolatedAngleDeg);
}

TEST(Pipeline, GlobsExpandInSortedOrder) {
  const auto dir = test::caseDir();
  // Made in reverse order, so a listing in the order of creation would fail.
  const std::vector<std::string> names = {"e.tif", "d.tif", "c.tif", "b.tif", "a.tif"};
  for (std::size_t k = 0; k < names.size(); ++k) {
    std::filesystem::copy_file(k % 2 ? geographicFallback() : demWithVoid(), dir / names[k]);
  }
  const dem::DemSource dem({(dir / "*.tif").string()});
  std::string sorted;
  for (auto name = names.rbegin(); name != names.rend(); ++name) {
    sorted += (sorted.empty() ? "" : ", ") + (dir / *name).string();
  }
  EXPECT_EQ(dem.info().path, sorted);
  EXPECT_THROW(dem::DemSource({(dir / "*.hgt").string()}), InputError);
}

}  // namespace
}  // namespace terrabake

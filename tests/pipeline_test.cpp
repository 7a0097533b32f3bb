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

std::map<std::string, std::string> filesOf(const std::filesystem::path& layer) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(layer)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files[std::filesystem::relative(entry.path(), layer).string()] =
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

TEST(Pipeline, HolesAreFilledAndVoidTilesAreNotWritten) {
  config::TileJob job = test::tileJob(demWithHoles(), "pipeline/holes", "native", 1, 1);
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

TEST(Pipeline, WorkerCountDoesNotChangeAByte) {
  const auto dem = test::sharedFixture("analytic_utm33_256.tif", [](const auto& path) {
    test_support::writeUtmDem(path, 15.3, 60.0, 30.0, 256, 256);
  });
  config::TileJob one = test::tileJob(dem, "pipeline/workers1", "webmercator", 11, 13);
  one.tile_size = 128;
  one.workers = 1;
  config::TileJob two = one;
  two.output_dir = test::testOutput("pipeline/workers2").string();
  two.workers = 2;
  ASSERT_EQ(pipeline::runTileJob(one).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(two).failed, 0);
  const auto a = filesOf(test::layerDir(one)), b = filesOf(test::layerDir(two));
  EXPECT_GT(a.size(), 10u);
  EXPECT_TRUE(a == b) << "layers made with 1 and 2 workers differ";
}

}  // namespace
}  // namespace terrabake

// output.elevation: every pixel of {y}.elevation.png, decoded by the
// published Terrarium and Terrain-RGB formulas (written here, not taken from
// terrabake), gives the height the bake used at that texel centre within
// half the format's step, on a DEM that reaches below sea level; and the
// settings that cannot hold elevation tiles are refused.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "bake/encode.hpp"
#include "core/error.hpp"
#include "layer_check.hpp"
#include "pipeline/layer_plan.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;

// Float32 vertex positions of the high-res mesh, in the frame of a tile
// centre at most about 5 km away at zoom 12: 5 km * 2^-24 is 0.3 mm, so
// heights read back from them are within this of what the bake used.
constexpr double kFloat32PositionM = 0.002;

// A coast in EPSG:4326 around lon 0.2, lat 0.2: 0.4 x 0.4 degrees of
// 0.002-degree pixels; sea floor sloping from 0 to -600 m in the west, hills
// up to about 400 m in the east.
fs::path coastDem() {
  return test::sharedFixture("coast_bathymetry.tif", [](const fs::path& path) {
    constexpr int kPixels = 200;
    constexpr double kSizeDeg = 0.4;
    ts::writeFloatDem(path, 4326, {0.0, kSizeDeg / kPixels, 0, kSizeDeg, 0, -kSizeDeg / kPixels}, kPixels, kPixels,
                      [](double lon, double lat) {
                        const double x = lon / kSizeDeg, y = (kSizeDeg - lat) / kSizeDeg;
                        return x < 0.5 ? -1200.0 * (0.5 - x)
                                       : 400.0 * std::sin(6.0 * x) * std::cos(5.0 * y) + 300.0 * (x - 0.5);
                      });
  });
}

struct Decoded {
  std::size_t texels = 0;
  double max_error_m = 0;
  double min_height_m = 1e9;
};

// Decodes every elevation pixel of every tile and compares it with the
// height of the high-res mesh's vertex at the same texel centre.
Decoded decodeLayer(const fs::path& layer, Elevation encoding) {
  Decoded result;
  const GeographicLib::Geocentric& earth = GeographicLib::Geocentric::WGS84();
  for (const auto& entry : fs::recursive_directory_iterator(layer)) {
    const std::string name = entry.path().filename().string();
    const std::string suffix = ".elevation.png";
    if (name.size() <= suffix.size() || name.substr(name.size() - suffix.size()) != suffix) continue;
    const std::string stem = name.substr(0, name.size() - suffix.size());
    const test_support::PngImage png = test_support::readPng(entry.path());
    EXPECT_EQ(png.bits, 8);
    EXPECT_EQ(png.channels, 3);
    const test_support::GlbMesh hires = test_support::readGlb(entry.path().parent_path() / (stem + ".hires.glb"), false);
    const int size = png.width;
    const auto& m = hires.enu_to_ecef;
    for (std::size_t k = 0; k < hires.position.size(); ++k) {
      const int i = int(std::lround(hires.uv[k].x * size - 0.5)), j = int(std::lround(hires.uv[k].y * size - 0.5));
      if (i >= size || j >= size) continue;  // the next tile's first texel
      const glm::dvec3 p = hires.position[k];
      const double ex = m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12];
      const double ey = m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13];
      const double ez = m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14];
      double lat = 0, lon = 0, height = 0;
      earth.Reverse(ex, ey, ez, lat, lon, height);
      const double r = png.sample(i, j, 0), g = png.sample(i, j, 1), b = png.sample(i, j, 2);
      // The published formulas.
      const double decoded = encoding == Elevation::kTerrarium ? r * 256 + g + b / 256 - 32768
                                                               : -10000 + (r * 65536 + g * 256 + b) * 0.1;
      result.max_error_m = std::max(result.max_error_m, std::abs(decoded - height));
      result.min_height_m = std::min(result.min_height_m, decoded);
      ++result.texels;
    }
  }
  return result;
}

void expectRoundTrip(Elevation encoding, double step_m) {
  config::TileJob job = test::tileJob(coastDem(), std::string("elevation_") + std::string(wordOf(encoding)),
                                      SchemeKind::kWebMercator, 11, 12);
  job.tile_size = 64;
  job.backend = Backend::kCpu;
  job.high_res_mesh = true;
  job.elevation = encoding;
  fs::remove_all(test::layerDir(job));
  const pipeline::RunSummary run = pipeline::runTileJob(job, {});
  ASSERT_GT(run.written, 0);
  const Decoded decoded = decodeLayer(test::layerDir(job), encoding);
  EXPECT_EQ(decoded.texels, std::size_t(run.written) * 64 * 64);
  EXPECT_LE(decoded.max_error_m, step_m / 2 + kFloat32PositionM);
  EXPECT_LT(decoded.min_height_m, -400.0) << "the DEM's sea floor should be in the tiles";

  // elevation.json is what MapLibre's raster-dem source reads.
  const auto tilejson = nlohmann::json::parse(test::readBytes(test::layerDir(job) / "elevation.json"));
  EXPECT_EQ(tilejson.at("encoding"), std::string(wordOf(encoding)));
  EXPECT_EQ(tilejson.at("tileSize"), 64);
  EXPECT_EQ(tilejson.at("minzoom"), 11);
  EXPECT_EQ(tilejson.at("maxzoom"), 12);
  EXPECT_EQ(tilejson.at("tiles").at(0), "./{z}/{x}/{y}.elevation.png");
  EXPECT_EQ(tilejson.at("bounds").size(), 4u);
}

TEST(Elevation, TerrariumDecodesToTheBakedHeightsWithinHalfAStep) { expectRoundTrip(Elevation::kTerrarium, 1.0 / 256); }

TEST(Elevation, TerrainRgbDecodesToTheBakedHeightsWithinHalfAStep) { expectRoundTrip(Elevation::kMapbox, 0.1); }

TEST(Elevation, EncodingRoundsToTheNearestStepAndClampsOutOfRange) {
  Raster<float> heights(2, 2);
  heights.data = {0.0f, -10.25f, -20000.0f, 40000.0f};
  const bake::ElevationImage terrarium = bake::encodeElevation(heights, 0, 2, Elevation::kTerrarium);
  const std::vector<std::uint16_t> expected_terrarium = {128, 0, 0, 127, 245, 192, 49, 224, 0, 255, 255, 255};
  EXPECT_EQ(terrarium.image.pixels, expected_terrarium);
  EXPECT_EQ(terrarium.clamped, 1u);  // 40000 m
  const bake::ElevationImage mapbox = bake::encodeElevation(heights, 0, 2, Elevation::kMapbox);
  // 0 m: 100000 = 0x0186a0; -10.25 m: 99897.5 rounds up to 99898 = 0x01863a; -20000 m clamps to 0;
  // 40000 m: 500000 = 0x07a120.
  const std::vector<std::uint16_t> expected_mapbox = {1, 134, 160, 1, 134, 58, 0, 0, 0, 7, 161, 32};
  EXPECT_EQ(mapbox.image.pixels, expected_mapbox);
  EXPECT_EQ(mapbox.clamped, 1u);  // -20000 m
}

TEST(Elevation, OnlyWebmercatorAndNotMbtiles) {
  config::TileJob job = test::tileJob(coastDem(), "elevation_refused", SchemeKind::kGeodetic, 11, 11);
  job.elevation = Elevation::kTerrarium;
  try {
    pipeline::planLayer(job);
    ADD_FAILURE() << "geodetic elevation tiles were not refused";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("only the webmercator scheme"), std::string::npos) << e.what();
  }
  job.scheme = SchemeKind::kWebMercator;
  job.format = OutputFormat::kMbtiles;
  EXPECT_THROW(pipeline::planLayer(job), UsageError);
}

}  // namespace
}  // namespace terrabake

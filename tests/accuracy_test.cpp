// Accuracy against an analytic terrain: every texel of every tile is
// decoded with its own tile's .glb, as docs/CONTRACT.md §4 says a renderer
// does, and compared with the terrain's exact normal.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

namespace ts = test_support;

// 8 bits: glTF decoding cannot represent an exact zero (128 decodes to
// +1/255), so an untilted normal already decodes about 0.32 degrees off;
// quantisation of tilted normals averages less. docs/CONTRACT.md §4 states these bounds.
constexpr double kMaxMeanDeg8 = 0.35;
constexpr double kMaxP99Deg8 = 0.6;
// 16 bits: quantisation is negligible; what remains is how well a mesh with a
// vertex per sample represents the smooth surface.
constexpr double kMaxMeanDeg16 = 0.05;
constexpr double kMaxP99Deg16 = 0.1;
// Texels closer than this to the DEM's edge (in DEM pixels) are not judged:
// beyond the edge there are no samples, and the contract lets the bake
// extrapolate there.
constexpr double kEdgeMarginPx = 25;

constexpr double kCentreLon = 15.3, kCentreLat = 60.0;  // UTM zone 33, 60 degrees north
constexpr int kDemPixels = 512;
constexpr double kPixelM = 30.0;

struct AngleStats {
  std::size_t count = 0;
  double mean = 0, p99 = 0, max = 0;
};

AngleStats summarise(std::vector<double> angles) {
  AngleStats s;
  s.count = angles.size();
  if (angles.empty()) return s;
  std::sort(angles.begin(), angles.end());
  double sum = 0;
  for (double a : angles) sum += a;
  s.mean = sum / double(angles.size());
  s.p99 = angles[std::min(angles.size() - 1, std::size_t(double(angles.size()) * 0.99))];
  s.max = angles.back();
  return s;
}

// The tiles a layer folder holds at `zoom`, from its images.
std::vector<TileId> tilesOfZoom(const std::filesystem::path& layer, int zoom) {
  std::vector<TileId> tiles;
  for (const auto& column : std::filesystem::directory_iterator(layer / std::to_string(zoom))) {
    const int x = std::stoi(column.path().filename().string());
    for (const auto& file : std::filesystem::directory_iterator(column.path())) {
      if (file.path().extension() == ".png") tiles.push_back({zoom, x, std::stoi(file.path().stem().string())});
    }
  }
  return tiles;
}

enum class DemCrs { kUtm, kGeographic };

struct Case {
  DemCrs crs;
  SchemeKind scheme;
  int bits;
};

std::string caseName(const Case& c) {
  return std::string(c.crs == DemCrs::kUtm ? "utm" : "geographic") + "_" + std::string(wordOf(c.scheme)) + "_" +
         std::to_string(c.bits) + "bit";
}

std::filesystem::path demFor(DemCrs crs) {
  if (crs == DemCrs::kUtm) {
    return test::analyticUtmDem(kDemPixels);
  }
  // About 30 m square pixels at 60 degrees north: a degree of longitude is
  // half as long as a degree of latitude there.
  return test::sharedFixture("analytic_epsg4326_512.tif", [](const auto& path) {
    const double lat_deg = kPixelM / 111320.0;
    ts::writeGeographicDem(path, kCentreLon, kCentreLat, 2 * lat_deg, lat_deg, kDemPixels, kDemPixels);
  });
}

class Accuracy : public ::testing::TestWithParam<Case> {};

TEST_P(Accuracy, DecodedNormalsMatchTheAnalyticTerrain) {
  const Case c = GetParam();
  const auto dem = demFor(c.crs);
  const test::DemGeometry geometry(dem);
  // Web Mercator zoom 12 has 19 m texels at 60 degrees north, the finest
  // zoom that does not undersample a 30 m DEM by more than 2x; native's
  // deepest level is the DEM's own grid.
  const bool native = c.scheme == SchemeKind::kNative;
  const int zoom = native ? 1 : 12;
  config::TileJob job = test::tileJob(dem, "accuracy/" + caseName(c), c.scheme, zoom, zoom);
  job.bits = c.bits;
  const auto summary = pipeline::runTileJob(job);
  ASSERT_GT(summary.written, 0);
  ASSERT_EQ(summary.failed, 0);

  std::vector<double> angles;
  std::size_t undecodable = 0;
  for (const TileId& tile : tilesOfZoom(test::layerDir(job), zoom)) {
    const test::DecodedTile decoded = test::readTile(test::layerDir(job), tile);
    const int size = decoded.png.width;
    for (int j = 0; j < size; ++j) {
      for (int i = 0; i < size; ++i) {
        // Native texels are DEM pixels; Web Mercator texels are located
        // with the spherical Mercator formulas.
        const glm::dvec2 lon_lat = native ? geometry.lonLatOfPixel(tile.x * size + i + 0.5, tile.y * size + j + 0.5)
                                          : test::webMercatorTexelLonLat(tile, size, i, j);
        if (!geometry.wellInside(geometry.pixelOf(lon_lat), kEdgeMarginPx)) continue;
        const auto n = decoded.ecefNormal(i, j);
        if (!n) {
          ++undecodable;
          continue;
        }
        angles.push_back(test::angleBetweenDeg(*n, ts::normalEcef(lon_lat.x, lon_lat.y)));
      }
    }
  }
  EXPECT_EQ(undecodable, 0u);
  const AngleStats s = summarise(angles);
  std::printf("%s: %zu texels, mean %.4f deg, p99 %.4f deg, max %.4f deg\n", caseName(c).c_str(), s.count,
              s.mean, s.p99, s.max);
  ASSERT_GT(s.count, 100000u);
  EXPECT_LE(s.mean, c.bits == 8 ? kMaxMeanDeg8 : kMaxMeanDeg16);
  EXPECT_LE(s.p99, c.bits == 8 ? kMaxP99Deg8 : kMaxP99Deg16);
}

std::vector<Case> allCases() {
  std::vector<Case> cases;
  for (DemCrs crs : {DemCrs::kUtm, DemCrs::kGeographic}) {
    for (const SchemeKind scheme : {SchemeKind::kWebMercator, SchemeKind::kNative}) {
      for (int bits : {8, 16}) cases.push_back({crs, scheme, bits});
    }
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(AnalyticTerrain, Accuracy, ::testing::ValuesIn(allCases()),
                         [](const auto& test_info) { return caseName(test_info.param); });

// On rough terrain the low-poly frame bends sharply across ridges, where a
// frame whose bitangent is made per pixel from the interpolated N and T
// differs from the renderers' (per-vertex bitangent, interpolated) by up to
// about 11 degrees. Decoding the renderers' way must give back the high-res
// normal at every texel, to 16-bit quantisation: one step in 16 bits is
// 2 / 65535 of a unit component, about 0.002 degrees, and a component may be
// off by half a step in each of three channels.
constexpr double kMaxRendererFrameP99Deg = 0.005;
constexpr double kMaxRendererFrameDeg = 0.02;

TEST(RendererFrame, RoughTerrainDecodesToTheHighResNormalsEverywhere) {
  const auto dem = std::filesystem::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif";
  constexpr int kZoom = 12;
  config::TileJob job = test::tileJob(dem, "accuracy/renderer_frame", SchemeKind::kWebMercator, kZoom, kZoom);
  job.bits = 16;
  job.high_res_mesh = true;  // its vertex (i, j) carries the normal the bake targets at texel (i, j)
  job.backend = Backend::kCpu;
  job.bbox = {9.95, 46.45, 10.05, 46.55};  // the ridged middle of the sample
  const auto summary = pipeline::runTileJob(job);
  ASSERT_GT(summary.written, 0);

  std::vector<double> angles;
  for (const TileId& tile : tilesOfZoom(test::layerDir(job), kZoom)) {
    const test::DecodedTile decoded = test::readTile(test::layerDir(job), tile);
    const auto high = ts::readGlb(test::layerDir(job) / std::to_string(kZoom) / std::to_string(tile.x) /
                                  (std::to_string(tile.y) + ".hires.glb"),
                                  false);
    const int size = decoded.png.width;
    for (int j = 0; j < size; ++j) {
      for (int i = 0; i < size; ++i) {
        const auto n = decoded.ecefNormal(i, j);
        ASSERT_TRUE(n.has_value()) << tile.str() << " texel " << i << ", " << j;
        const glm::dvec3 target = high.normal[std::size_t(j) * (size + 1) + std::size_t(i)];
        angles.push_back(test::angleBetweenDeg(*n, ts::localToEcefDirection(high, target)));
      }
    }
  }
  const AngleStats s = summarise(angles);
  std::printf("renderer frame on the sample, zoom %d, 16 bits: %zu texels, mean %.4f deg, p99 %.4f deg, max %.4f deg\n",
              kZoom, s.count, s.mean, s.p99, s.max);
  EXPECT_LE(s.p99, kMaxRendererFrameP99Deg);
  EXPECT_LE(s.max, kMaxRendererFrameDeg);
}

}  // namespace
}  // namespace terrabake

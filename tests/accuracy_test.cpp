// Accuracy against an analytic terrain: every texel of every tile is
// decoded with its own tile's .glb, as docs/CONTRACT.md §4 says a renderer
// does, and compared with the terrain's exact normal.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include <glm/trigonometric.hpp>

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

using AngleStats = test::Stats;
using test::summarise;

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
  LowPolyMesh mesh = LowPolyMesh::kAdaptive;
};

std::string caseName(const Case& c) {
  return std::string(c.crs == DemCrs::kUtm ? "utm" : "geographic") + "_" + std::string(wordOf(c.scheme)) + "_" +
         std::to_string(c.bits) + "bit" + (c.mesh == LowPolyMesh::kGrid ? "_grid" : "");
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
  job.low_poly_mesh = c.mesh;
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
  // The regular grid holds the same bounds.
  for (int bits : {8, 16}) cases.push_back({DemCrs::kUtm, SchemeKind::kWebMercator, bits, LowPolyMesh::kGrid});
  return cases;
}

INSTANTIATE_TEST_SUITE_P(AnalyticTerrain, Accuracy, ::testing::ValuesIn(allCases()),
                         [](const auto& test_info) { return caseName(test_info.param); });

// ------------------------------------------------------------ the pyramid
// Every zoom from three levels coarser than the DEM's own (the deepest whose
// texels are no smaller than its pixels) to one level finer, in both global
// schemes, from a projected and a geographic DEM. Texels span 0.5 to 15 DEM
// pixels a side and never a whole number of them, so coarse zooms low-pass
// the DEM with footprints that fall on the pixel grid at every phase: a
// texel whose height depended on that phase, not only on its position,
// would show as normal noise on every slope.

// 16 bits: the decoding floor is about 0.001 degrees (mean) and the broad
// hills' own approximation error under 0.003 (BroadHills test below), while
// footprint centres off by up to a twentieth of a pixel, as with GDAL's area
// mean, cost 0.08 to 0.17 degrees (mean) on their slopes. 8 bits: the bounds
// of docs/CONTRACT.md §4, above.
constexpr double kPyramidMaxMeanDeg16 = 0.01;
constexpr double kPyramidMaxP99Deg16 = 0.05;
constexpr int kZoomsCoarser = 3, kZoomsFiner = 1;
// Texels at least this far (in pixels) from a whole number of pixels drift
// across the pixel grid through every phase within 25 texels.
constexpr double kMinRatioFraction = 0.04;
// A texel's normal reads the heights of its neighbours, each filtered over a
// texel or more: three texels in from the DEM's edge none of that reaches
// past it (nearer, kEdgeMarginPx still applies).
constexpr double kEdgeMarginTexels = 3;
// Enough texels at the coarsest zoom for a stable 99th percentile.
constexpr std::size_t kMinTexelsPerZoom = 5000;

constexpr int kPyramidTileSize = 64;
// UTM zone 33, 2.5 degrees east of its central meridian, so the DEM's grid
// turns 2 degrees against the schemes' north.
constexpr double kPyramidLon = 17.5, kPyramidLat = 55.0;
constexpr int kPyramidDemPixels = 1536;
constexpr double kUtmPixelM = 10.0;
// 1/3 arc-second (as USGS 3DEP): 10.3 m north-south, 5.9 m east-west here.
constexpr double kGeographicPixelDeg = 1.0 / 10800;

// Metres per degree east and north on WGS84 at a latitude.
glm::dvec2 metresPerDegree(double lat_deg) {
  constexpr double kA = 6378137.0, kE2 = 0.00669437999014;
  const double s = std::sin(lat_deg * M_PI / 180), w = std::sqrt(1 - kE2 * s * s);
  return {M_PI / 180 * kA * std::cos(lat_deg * M_PI / 180) / w, M_PI / 180 * kA * (1 - kE2) / (w * w * w)};
}

// Ground size (east, north) in metres of a texel at `zoom` near the DEM.
glm::dvec2 texelSizeM(SchemeKind scheme, int zoom) {
  const double span_deg = (scheme == SchemeKind::kWebMercator ? 360.0 : 180.0) / (kPyramidTileSize * double(1 << zoom));
  const glm::dvec2 m = metresPerDegree(kPyramidLat);
  // Web Mercator is conformal: as long north-south as east-west.
  return scheme == SchemeKind::kWebMercator ? glm::dvec2(span_deg * m.x) : span_deg * m;
}

glm::dvec2 demPixelSizeM(DemCrs crs) {
  return crs == DemCrs::kUtm ? glm::dvec2(kUtmPixelM) : kGeographicPixelDeg * metresPerDegree(kPyramidLat);
}

// Texel over pixel, east and north.
glm::dvec2 texelsPerPixel(const Case& c, int zoom) { return texelSizeM(c.scheme, zoom) / demPixelSizeM(c.crs); }

int demZoom(const Case& c) {
  int zoom = 0;
  while (zoom < kMaxZoom) {
    const glm::dvec2 next = texelsPerPixel(c, zoom + 1);
    if (next.x * next.y < 1) break;
    ++zoom;
  }
  return zoom;
}

std::filesystem::path pyramidDemFor(DemCrs crs) {
  if (crs == DemCrs::kUtm) {
    return test::sharedFixture("broad_hills_utm33_1536.tif", [](const auto& path) {
      ts::writeUtmDem(path, kPyramidLon, kPyramidLat, kUtmPixelM, kPyramidDemPixels, kPyramidDemPixels,
                      ts::kBroadHills);
    });
  }
  return test::sharedFixture("broad_hills_epsg4326_1536.tif", [](const auto& path) {
    ts::writeGeographicDem(path, kPyramidLon, kPyramidLat, kGeographicPixelDeg, kGeographicPixelDeg,
                           kPyramidDemPixels, kPyramidDemPixels, ts::kBroadHills);
  });
}

class Pyramid : public ::testing::TestWithParam<Case> {};

TEST_P(Pyramid, EveryZoomDecodesToTheAnalyticTerrain) {
  const Case c = GetParam();
  const auto dem = pyramidDemFor(c.crs);
  const test::DemGeometry geometry(dem);
  const int dem_zoom = demZoom(c);
  for (int zoom = dem_zoom - kZoomsCoarser; zoom <= dem_zoom + kZoomsFiner; ++zoom) {
    const glm::dvec2 ratio = texelsPerPixel(c, zoom);
    for (double r : {ratio.x, ratio.y}) EXPECT_GE(std::abs(r - std::round(r)), kMinRatioFraction) << "zoom " << zoom;
    config::TileJob job = test::tileJob(dem, "accuracy/pyramid_" + caseName(c) + "_z" + std::to_string(zoom),
                                        c.scheme, zoom, zoom);
    job.tile_size = kPyramidTileSize;
    job.bits = c.bits;
    job.backend = Backend::kCpu;
    // A few tiles around the centre: all the DEM at coarse zooms, a patch of it at fine ones.
    const glm::dvec2 half_deg = 1.5 * kPyramidTileSize * texelSizeM(c.scheme, zoom) / metresPerDegree(kPyramidLat);
    job.bbox = {kPyramidLon - half_deg.x, kPyramidLat - half_deg.y, kPyramidLon + half_deg.x,
                kPyramidLat + half_deg.y};
    const auto summary = pipeline::runTileJob(job);
    ASSERT_GT(summary.written, 0) << "zoom " << zoom;
    ASSERT_EQ(summary.failed, 0) << "zoom " << zoom;

    const double margin_px = std::max(kEdgeMarginPx, kEdgeMarginTexels * std::max(ratio.x, ratio.y));
    std::vector<double> angles;
    std::size_t undecodable = 0;
    for (const TileId& tile : tilesOfZoom(test::layerDir(job), zoom)) {
      const test::DecodedTile decoded = test::readTile(test::layerDir(job), tile);
      for (int j = 0; j < kPyramidTileSize; ++j) {
        for (int i = 0; i < kPyramidTileSize; ++i) {
          const glm::dvec2 lon_lat = c.scheme == SchemeKind::kWebMercator
                                         ? test::webMercatorTexelLonLat(tile, kPyramidTileSize, i, j)
                                         : test::geodeticTexelLonLat(tile, kPyramidTileSize, i, j);
          if (!geometry.wellInside(geometry.pixelOf(lon_lat), margin_px)) continue;
          const auto n = decoded.ecefNormal(i, j);
          if (!n) {
            ++undecodable;
            continue;
          }
          angles.push_back(test::angleBetweenDeg(*n, ts::normalEcef(lon_lat.x, lon_lat.y, ts::kBroadHills)));
        }
      }
    }
    const AngleStats s = summarise(angles);
    std::printf("%s zoom %d (dem %+d), %.3f x %.3f px per texel: %zu texels, mean %.4f deg, p99 %.4f deg, max %.4f deg\n",
                caseName(c).c_str(), zoom, zoom - dem_zoom, ratio.x, ratio.y, s.count, s.mean, s.p99, s.max);
    EXPECT_EQ(undecodable, 0u) << "zoom " << zoom;
    EXPECT_GE(s.count, kMinTexelsPerZoom) << "zoom " << zoom;
    EXPECT_LE(s.mean, c.bits == 8 ? kMaxMeanDeg8 : kPyramidMaxMeanDeg16) << "zoom " << zoom;
    EXPECT_LE(s.p99, c.bits == 8 ? kMaxP99Deg8 : kPyramidMaxP99Deg16) << "zoom " << zoom;
  }
}

std::vector<Case> pyramidCases() {
  std::vector<Case> cases;
  for (DemCrs crs : {DemCrs::kUtm, DemCrs::kGeographic}) {
    for (const SchemeKind scheme : {SchemeKind::kWebMercator, SchemeKind::kGeodetic}) {
      for (int bits : {8, 16}) cases.push_back({crs, scheme, bits});
    }
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(BroadHills, Pyramid, ::testing::ValuesIn(pyramidCases()),
                         [](const auto& test_info) { return caseName(test_info.param); });

// The broad hills' curvature is small enough that what the bake rightly does
// at a coarse texel (heights low-passed over the texel, normals from central
// differences two texels apart) leaves their normals all but exact, so the
// pyramid's bounds judge resampling errors alone. Checked in the UTM plane:
// the normal of the surface box-filtered over a texel and differenced across
// its neighbours against the exact normal, at points all over the DEM.
constexpr double kCoarsestTexelM = 160;  // the pyramid's largest texel side is 153 m
constexpr double kMaxModelErrorDeg = 0.003;

TEST(BroadHills, FilteringAndDifferencingAtTheCoarsestTexelsMoveNormalsNegligibly) {
  constexpr int kPoints = 40, kBoxSamples = 16;
  const glm::dvec2 centre = ts::utm33(kPyramidLon, kPyramidLat);
  const double span_m = kPyramidDemPixels * kUtmPixelM;
  auto boxFiltered = [](double e, double n) {
    double sum = 0;
    for (int b = 0; b < kBoxSamples; ++b) {
      for (int a = 0; a < kBoxSamples; ++a) {
        sum += ts::heightUtm(e + ((a + 0.5) / kBoxSamples - 0.5) * kCoarsestTexelM,
                             n + ((b + 0.5) / kBoxSamples - 0.5) * kCoarsestTexelM, ts::kBroadHills);
      }
    }
    return sum / (kBoxSamples * kBoxSamples);
  };
  auto normalOfSlope = [](double de, double dn) { return glm::normalize(glm::dvec3(-de, -dn, 1)); };
  double worst = 0;
  for (int q = 0; q < kPoints; ++q) {
    for (int p = 0; p < kPoints; ++p) {
      const double e = centre.x + ((p + 0.5) / kPoints - 0.5) * span_m;
      const double n = centre.y + ((q + 0.5) / kPoints - 0.5) * span_m;
      constexpr double kStepM = 0.01;
      const glm::dvec3 exact = normalOfSlope(
          (ts::heightUtm(e + kStepM, n, ts::kBroadHills) - ts::heightUtm(e - kStepM, n, ts::kBroadHills)) / (2 * kStepM),
          (ts::heightUtm(e, n + kStepM, ts::kBroadHills) - ts::heightUtm(e, n - kStepM, ts::kBroadHills)) / (2 * kStepM));
      const glm::dvec3 baked =
          normalOfSlope((boxFiltered(e + kCoarsestTexelM, n) - boxFiltered(e - kCoarsestTexelM, n)) / (2 * kCoarsestTexelM),
                        (boxFiltered(e, n + kCoarsestTexelM) - boxFiltered(e, n - kCoarsestTexelM)) / (2 * kCoarsestTexelM));
      worst = std::max(worst, test::angleBetweenDeg(exact, baked));
    }
  }
  std::printf("broad hills at %.0f m texels: filtering and central differences move normals by %.5f deg at most\n",
              kCoarsestTexelM, worst);
  EXPECT_LE(worst, kMaxModelErrorDeg);
}

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

// Angles between the normal each texel of a geodetic layer's tiles at
// `zooms` decodes to and `expected` at the texel's centre; a texel on no
// triangle fails the test and is left out.
std::vector<double> geodeticTexelAngles(const std::filesystem::path& layer, std::initializer_list<int> zooms,
                                        int tile_size, glm::dvec3 (*expected)(double lon_deg, double lat_deg)) {
  std::vector<double> angles;
  for (int zoom : zooms) {
    for (const TileId& tile : tilesOfZoom(layer, zoom)) {
      const test::DecodedTile decoded = test::readTile(layer, tile);
      for (int j = 0; j < tile_size; ++j) {
        for (int i = 0; i < tile_size; ++i) {
          const auto n = decoded.ecefNormal(i, j);
          if (!n) {
            ADD_FAILURE() << tile.str() << " texel " << i << ", " << j << " is on no triangle";
            continue;
          }
          const glm::dvec2 lon_lat = test::geodeticTexelLonLat(tile, tile_size, i, j);
          angles.push_back(test::angleBetweenDeg(*n, expected(lon_lat.x, lon_lat.y)));
        }
      }
    }
  }
  return angles;
}

// A whole-world DEM of the ellipsoid itself (height 0 in EPSG:4326, 5-degree
// pixels), tiled in the geodetic scheme at zooms 0-1: every tile reaches a
// pole, and its apron past it. Each texel, the polar rows included, decodes to
// the ellipsoid's normal there within the 8-bit bounds above. Before the
// apron's latitudes past a pole were taken round the meridian, every such tile
// failed ("position is not finite"), and before the frames at a pole were
// taken along their meridians, the texels near it decoded upside down.
TEST(WholeWorld, TilesReachingThePolesDecodeToTheEllipsoidsNormal) {
  constexpr int kWorldTileSize = 32;
  const auto dem = test::sharedFixture("flat_world_epsg4326.tif", [](const auto& path) {
    ts::writeFloatDem(path, 4326, {-180, 5, 0, 90, 0, -5}, 72, 36, [](double, double) { return 0.0; });
  });
  const std::filesystem::path out = test::caseDir();
  config::TileJob job = test::tileJob(dem, "", SchemeKind::kGeodetic, 0, 1);
  job.output_dir = (out / "geodetic").string();
  job.tile_size = kWorldTileSize;
  job.backend = Backend::kCpu;
  const auto summary = pipeline::runTileJob(job);
  EXPECT_EQ(summary.written, 2 + 8);
  ASSERT_EQ(summary.failed, 0);

  const AngleStats s =
      summarise(geodeticTexelAngles(test::layerDir(job), {0, 1}, kWorldTileSize, ts::ellipsoidUpEcef));
  std::printf("whole world, geodetic zooms 0-1: %zu texels, mean %.4f deg, p99 %.4f deg, max %.4f deg\n", s.count,
              s.mean, s.p99, s.max);
  EXPECT_LE(s.mean, kMaxMeanDeg8);
  EXPECT_LE(s.p99, kMaxP99Deg8);

  // The DEM's own (native) square tile reaches 90 degrees past the south
  // pole: it is made all the same, not failed.
  config::TileJob native = test::tileJob(dem, "", SchemeKind::kNative, 0, 0);
  native.output_dir = (out / "native").string();
  native.tile_size = kWorldTileSize;
  native.backend = Backend::kCpu;
  const auto native_summary = pipeline::runTileJob(native);
  EXPECT_EQ(native_summary.written, 1);
  EXPECT_EQ(native_summary.failed, 0);
}

// Tiles either side of the antimeridian are neighbours: on a whole-world
// DEM of hills that run on across it, their shared edge has the same
// vertices, frames and all (docs/CONTRACT.md §5), in both global schemes.
// The reprojection takes a Web Mercator apron past the edge the short way
// round, to the far side of the DEM; a row of lattice nodes then jumped a
// whole turn, and the edges stood up to 1.9 km apart at zoom 5.
// WGS84 geodetic to ECEF, metres.
glm::dvec3 geodeticToEcefM(double lon_deg, double lat_deg, double height_m) {
  constexpr double kA = 6378137.0, kE2 = 6.69437999014e-3;
  const double lon = glm::radians(lon_deg), lat = glm::radians(lat_deg);
  const double n = kA / std::sqrt(1 - kE2 * std::sin(lat) * std::sin(lat));
  return {(n + height_m) * std::cos(lat) * std::cos(lon), (n + height_m) * std::cos(lat) * std::sin(lon),
          (n * (1 - kE2) + height_m) * std::sin(lat)};
}

// Heights of a whole world of broad hills, a function of the ellipsoid's up
// direction alone, so smooth across the poles and the antimeridian.
double hillsOfUp(const glm::dvec3& up) {
  return 2000 * std::sin(3 * up.x + 1) * std::cos(4 * up.y) + 1500 * std::sin(5 * up.z + 2 * up.x);
}

// The exact normal of that surface at a point, by central differences over
// 20 m along two directions square to up: defined at a pole as anywhere.
glm::dvec3 hillsNormalEcef(double lon_deg, double lat_deg) {
  const glm::dvec3 up = ts::ellipsoidUpEcef(lon_deg, lat_deg);
  const glm::dvec3 first = glm::normalize(glm::cross(up, std::abs(up.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0)));
  const glm::dvec3 second = glm::cross(up, first);
  constexpr double kStep = 20.0 / 6378137.0;
  const auto point = [&](const glm::dvec3& offset) {
    const glm::dvec3 u = glm::normalize(up + offset * kStep);
    return geodeticToEcefM(glm::degrees(std::atan2(u.y, u.x)), glm::degrees(std::asin(u.z)), hillsOfUp(u));
  };
  return glm::normalize(glm::cross(point(first) - point(-first), point(second) - point(-second)));
}

// Frames on a pole: every vertex there is the pole, but interpolation across
// it puts them a few metres apart as the heights either side differ, so the
// difference along the pole's row was noise of those heights, and frames
// there came out turned round (texels in lines 33 degrees off). Whole-world
// hills in the geodetic scheme at zooms 0-2: every texel, the polar ones
// included, decodes to the surface's normal within the 8-bit p99 bound.
TEST(WholeWorld, HillsAcrossThePolesDecodeToTheirNormalAtEveryTexel) {
  constexpr int kWorldTileSize = 64;
  constexpr double kPixelDeg = 0.5;
  const auto dem = test::sharedFixture("hills_world_epsg4326.tif", [&](const auto& path) {
    ts::writeFloatDem(path, 4326, {-180, kPixelDeg, 0, 90, 0, -kPixelDeg}, 720, 360,
                      [](double lon, double lat) { return hillsOfUp(ts::ellipsoidUpEcef(lon, lat)); });
  });
  config::TileJob job = test::tileJob(dem, "", SchemeKind::kGeodetic, 0, 2);
  job.output_dir = (test::caseDir() / "geodetic").string();
  job.tile_size = kWorldTileSize;
  job.backend = Backend::kCpu;
  const auto summary = pipeline::runTileJob(job);
  ASSERT_EQ(summary.written, 2 + 8 + 32);
  const AngleStats s =
      summarise(geodeticTexelAngles(test::layerDir(job), {0, 1, 2}, kWorldTileSize, hillsNormalEcef));
  std::printf("whole-world hills, geodetic zooms 0-2: %zu texels, mean %.4f deg, p99 %.4f deg, max %.4f deg\n",
              s.count, s.mean, s.p99, s.max);
  EXPECT_EQ(s.count, std::size_t(42 * kWorldTileSize * kWorldTileSize));
  EXPECT_LE(s.mean, kMaxMeanDeg8);
  EXPECT_LE(s.max, kMaxP99Deg8);
}

TEST(WholeWorld, TilesEitherSideOfTheAntimeridianShareTheirEdge) {
  // A name of its own: a shared fixture is whichever test writes it first.
  const auto dem = test::sharedFixture("sine_world_epsg4326.tif", [](const auto& path) {
    ts::writeFloatDem(path, 4326, {-180, 0.5, 0, 90, 0, -0.5}, 720, 360, [](double lon, double lat) {
      const double c = std::cos(glm::radians(lat));
      return 3000 * std::sin(2 * glm::radians(lon) + 0.5) * c * c;
    });
  });
  constexpr int kZoom = 12;
  const std::filesystem::path out = test::caseDir();
  for (const SchemeKind scheme : {SchemeKind::kWebMercator, SchemeKind::kGeodetic}) {
    const std::string name(wordOf(scheme));
    const auto bake = [&](const std::string& side, double west, double east) {
      config::TileJob job = test::tileJob(dem, "", scheme, kZoom, kZoom);
      job.output_dir = (out / name / side).string();
      job.backend = Backend::kCpu;
      job.bbox = {west, -0.01, east, 0.01};
      const auto summary = pipeline::runTileJob(job);
      EXPECT_GT(summary.written, 0) << name << " " << side;
      return test::layerDir(job);
    };
    const std::filesystem::path west_of = bake("west_of", 179.99, 180), east_of = bake("east_of", -180, -179.99);
    const int last_column = (scheme == SchemeKind::kWebMercator ? 1 : 2) << kZoom;
    const int row = 1 << (kZoom - 1);  // the first south of the equator, in both schemes
    SCOPED_TRACE(name);
    test::expectSharedEdge(test::readTile(west_of, {kZoom, last_column - 1, row}).glb,
                           test::readTile(east_of, {kZoom, 0, row}).glb, true);
  }
}

}  // namespace
}  // namespace terrabake

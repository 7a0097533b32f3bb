// Where a layer's files put the terrain, against answers known without
// terrabake (docs/CONTRACT.md §2, §3, §5, §6): on a DEM whose heights are a
// plane in longitude and latitude, placed where the geoid lies 90 m below
// the ellipsoid, every vertex of every mesh sits at the DEM's height above
// the WGS84 ellipsoid times z_scale and exaggeration; each tile's frame is
// the east-north-up frame of its centre; high-res vertices sit on the texel
// centres and meet their neighbours'; elevation tiles decode to the DEM's
// heights; skirts hang the stated depth towards the earth's centre; tilejson
// bounds are the DEM's, clamped to Web Mercator's latitudes; and
// `output.green: down` stores -y.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "layer_check.hpp"
#include "test_helpers.hpp"
#include "tileset_walk.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;
using json = nlohmann::json;

// The DEM: EPSG:4326, 0.2 x 0.2 degrees of 0.001-degree pixels (110 m) south
// of India, where the geoid lies about 90 m below the ellipsoid, so heights
// taken as above the geoid would be off by that much. Its heights are a
// plane in longitude and latitude, which the cubic kernel reproduces
// exactly, so every texel's height is known.
constexpr double kWest = 78.0, kNorth = 8.2, kSizeDeg = 0.2, kPixelDeg = 0.001;
double demHeight(double lon, double lat) { return 1000 + 2000 * (lon - kWest) + 1500 * (lat - kNorth); }

// heights.z_scale and heights.exaggeration: the output is their product
// times the DEM's values.
constexpr double kZScale = 2, kExaggeration = 1.5;
double outputHeight(double lon, double lat) { return kZScale * kExaggeration * demHeight(lon, lat); }

// Tiles of 64 texels at zooms 13 and 14 have texels of 76 and 38 m here,
// finer than the pixels, so the cubic kernel reads them; a box in the DEM's
// middle keeps every tile's texels and apron on data (the tiles, 0.044° and
// 0.022° wide, reach at most 0.044° past the box, which lies 0.09° inside).
constexpr int kMinZoom = 13, kMaxZoom = 14, kTileSize = 64;
const std::vector<double> kBox = {kWest + 0.09, kNorth - 0.11, kWest + 0.11, kNorth - 0.09};

// Float32 vertex positions in the frame of a tile centre at most 3.4 km
// away (a zoom-13 tile is 4.8 km across): 3.4 km * 2^-24 rounds by 0.2 mm;
// 2 mm holds that with room for the double arithmetic between.
constexpr double kFloat32PositionM = 0.002;
// The same on the ground, in degrees of latitude (and of longitude, at 8° N).
constexpr double kFloat32PositionDeg = kFloat32PositionM / 110000;
// A frame's axes are unit vectors computed in double, written with 17
// significant digits.
constexpr double kFrameAxis = 1e-12;
// Heights pass through float32 twice: the DEM's samples (half an ulp of
// 1,100 m is 0.06 mm, times the scale of 3) and the heights the bake keeps
// (0.12 mm at 3,300 m), with the cubic kernel's sums between.
constexpr double kHeightRoundingM = 0.0005;
// Terrarium's step is 1/256 m.
constexpr double kTerrariumHalfStepM = 0.5 / 256;

fs::path planeDem() {
  return test::sharedFixture("plane_geoid_low.tif", [](const fs::path& path) {
    const int pixels = int(std::lround(kSizeDeg / kPixelDeg));
    ts::writeFloatDem(path, 4326, {kWest, kPixelDeg, 0, kNorth, 0, -kPixelDeg}, pixels, pixels, demHeight);
  });
}

struct Geodetic {
  double lon, lat, height;
};
Geodetic geodeticOf(const glm::dvec3& ecef) {
  Geodetic g{};
  GeographicLib::Geocentric::WGS84().Reverse(ecef.x, ecef.y, ecef.z, g.lat, g.lon, g.height);
  return g;
}

fs::path tileFile(const fs::path& layer, const TileId& t, const std::string& suffix) {
  return layer / std::to_string(t.z) / std::to_string(t.x) / (std::to_string(t.y) + suffix);
}

// The plane DEM's layer with every output that carries heights: low-poly
// meshes with skirts, high-res meshes and Terrarium elevation tiles. Made
// once per test process, in the folder of the first test that asks (ctest
// runs each test in a process of its own, side by side).
const fs::path& planeLayer() {
  static const fs::path layer = [] {
    config::TileJob job = test::tileJob(planeDem(), "unused", SchemeKind::kWebMercator, kMinZoom, kMaxZoom);
    job.output_dir = (test::caseDir() / "out").string();
    job.tile_size = kTileSize;
    job.bbox = kBox;
    job.z_scale = kZScale;
    job.exaggeration = kExaggeration;
    job.high_res_mesh = true;
    job.elevation = Elevation::kTerrarium;
    job.skirts = Skirts::kOn;
    job.backend = Backend::kCpu;
    fs::remove_all(test::layerDir(job));
    const pipeline::RunSummary run = pipeline::runTileJob(job, {});
    EXPECT_EQ(run.failed, 0);
    return test::layerDir(job);
  }();
  return layer;
}

// The skirt vertices of a low-poly mesh: copies of a border vertex (same UV,
// normal and tangent) at another position, each with the vertex it copies.
std::map<std::size_t, std::size_t> skirtCopies(const ts::GlbMesh& mesh) {
  std::map<std::pair<double, double>, std::size_t> first_at_uv;
  std::map<std::size_t, std::size_t> copies;
  for (std::size_t k = 0; k < mesh.uv.size(); ++k) {
    const auto [it, inserted] = first_at_uv.insert({{mesh.uv[k].x, mesh.uv[k].y}, k});
    if (!inserted && glm::length(mesh.position[k] - mesh.position[it->second]) > kFloat32PositionM) {
      copies[k] = it->second;
    }
  }
  return copies;
}

TEST(Placement, EveryVertexLiesAtTheDemsHeightAboveTheEllipsoidScaledAsAsked) {
  const fs::path& layer = planeLayer();
  const std::set<TileId> tiles = test::meshesOnDisk(layer);
  ASSERT_GE(tiles.size(), 4u);
  std::size_t vertices = 0;
  double worst_m = 0;
  for (const TileId& tile : tiles) {
    const ts::GlbMesh low = ts::readGlb(tileFile(layer, tile, ".glb"));
    const ts::GlbMesh high = ts::readGlb(tileFile(layer, tile, ".hires.glb"), false);
    const std::map<std::size_t, std::size_t> skirts = skirtCopies(low);
    ASSERT_FALSE(skirts.empty()) << tile.str();
    for (const ts::GlbMesh* mesh : {&low, &high}) {
      for (std::size_t k = 0; k < mesh->position.size(); ++k) {
        if (mesh == &low && skirts.count(k)) continue;
        const Geodetic g = geodeticOf(ts::localToEcefPoint(*mesh, mesh->position[k]));
        const double error_m = std::abs(g.height - outputHeight(g.lon, g.lat));
        worst_m = std::max(worst_m, error_m);
        EXPECT_LE(error_m, kFloat32PositionM) << tile.str() << " vertex " << k << " at " << g.lon << ", " << g.lat;
        ++vertices;
      }
    }
  }
  std::printf("%zu vertices of %zu tiles: at most %.5f m from the DEM's height above the ellipsoid\n", vertices,
              tiles.size(), worst_m);
}

TEST(Placement, EachTilesFrameIsTheEastNorthUpFrameOfItsCentre) {
  const fs::path& layer = planeLayer();
  for (const TileId& tile : test::meshesOnDisk(layer)) {
    const ts::GlbMesh low = ts::readGlb(tileFile(layer, tile, ".glb"));
    // The middle of the tile's extent: texel coordinate S / 2 both ways.
    const glm::dvec2 centre = test::webMercatorTexelLonLat(tile, kTileSize, kTileSize / 2 - 0.5, kTileSize / 2 - 0.5);
    EXPECT_NEAR(low.origin_lon, centre.x, 1e-9) << tile.str();
    EXPECT_NEAR(low.origin_lat, centre.y, 1e-9) << tile.str();
    const Geodetic origin = geodeticOf(ts::localToEcefPoint(low, {0, 0, 0}));
    EXPECT_NEAR(origin.lon, centre.x, 1e-9) << tile.str();
    EXPECT_NEAR(origin.lat, centre.y, 1e-9) << tile.str();
    EXPECT_NEAR(origin.height, 0, 1e-6) << tile.str();
    // glTF's +X east, +Y up, +Z south.
    const double lon = centre.x * M_PI / 180, lat = centre.y * M_PI / 180;
    const glm::dvec3 east(-std::sin(lon), std::cos(lon), 0);
    const glm::dvec3 north(-std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat));
    const glm::dvec3 up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
    EXPECT_LE(glm::length(ts::localToEcefDirection(low, {1, 0, 0}) - east), kFrameAxis) << tile.str();
    EXPECT_LE(glm::length(ts::localToEcefDirection(low, {0, 1, 0}) - up), kFrameAxis) << tile.str();
    EXPECT_LE(glm::length(ts::localToEcefDirection(low, {0, 0, 1}) + north), kFrameAxis) << tile.str();
    // The high-res mesh shares the frame.
    const ts::GlbMesh high = ts::readGlb(tileFile(layer, tile, ".hires.glb"), false);
    EXPECT_EQ(high.enu_to_ecef, low.enu_to_ecef) << tile.str();
  }
}

// The vertices of a high-res mesh by texel: (i, j) for i, j in 0..S, the
// last row and column being the next tiles' first texels.
std::map<std::pair<int, int>, glm::dvec3> highResByTexel(const ts::GlbMesh& high) {
  std::map<std::pair<int, int>, glm::dvec3> by_texel;
  for (std::size_t k = 0; k < high.uv.size(); ++k) {
    const double i = high.uv[k].x * kTileSize - 0.5, j = high.uv[k].y * kTileSize - 0.5;
    EXPECT_NEAR(i, std::round(i), 1e-4) << "a high-res vertex off the texel centres";
    EXPECT_NEAR(j, std::round(j), 1e-4) << "a high-res vertex off the texel centres";
    by_texel[{int(std::lround(i)), int(std::lround(j))}] = ts::localToEcefPoint(high, high.position[k]);
  }
  return by_texel;
}

// A high-res mesh's vertex at texel (i, j), in the tile's frame.
glm::dvec3 highResLocalAt(const ts::GlbMesh& high, int i, int j) {
  for (std::size_t k = 0; k < high.uv.size(); ++k) {
    if (std::lround(high.uv[k].x * kTileSize - 0.5) == i && std::lround(high.uv[k].y * kTileSize - 0.5) == j) {
      return high.position[k];
    }
  }
  ADD_FAILURE() << "no high-res vertex at texel " << i << ", " << j;
  return {};
}

TEST(Placement, HighResVerticesSitOnTexelCentresAndMeetTheNeighboursFirst) {
  const fs::path& layer = planeLayer();
  const std::set<TileId> tiles = test::meshesOnDisk(layer);
  std::map<TileId, std::map<std::pair<int, int>, glm::dvec3>> meshes;
  for (const TileId& tile : tiles) {
    meshes[tile] = highResByTexel(ts::readGlb(tileFile(layer, tile, ".hires.glb"), false));
    ASSERT_EQ(meshes[tile].size(), std::size_t(kTileSize + 1) * (kTileSize + 1)) << tile.str();
    for (const auto& [texel, ecef] : meshes[tile]) {
      const glm::dvec2 expected = test::webMercatorTexelLonLat(tile, kTileSize, texel.first, texel.second);
      const Geodetic g = geodeticOf(ecef);
      EXPECT_NEAR(g.lon, expected.x, kFloat32PositionDeg) << tile.str() << " texel " << texel.first << ", " << texel.second;
      EXPECT_NEAR(g.lat, expected.y, kFloat32PositionDeg) << tile.str() << " texel " << texel.first << ", " << texel.second;
    }
  }
  int seams = 0;
  for (const TileId& tile : tiles) {
    for (const TileId next : {TileId{tile.z, tile.x + 1, tile.y}, TileId{tile.z, tile.x, tile.y + 1}}) {
      if (!meshes.count(next)) continue;
      const bool east = next.x != tile.x;
      for (int k = 0; k <= kTileSize; ++k) {
        // This tile's last column (row) is the next one's first.
        const auto here = east ? std::pair{kTileSize, k} : std::pair{k, kTileSize};
        const auto there = east ? std::pair{0, k} : std::pair{k, 0};
        if (k == kTileSize) continue;  // the next tile's own next one
        EXPECT_LE(glm::length(meshes[tile][here] - meshes[next][there]), test::kMaxEdgeGapM)
            << tile.str() << " and " << next.str() << " at " << k;
      }
      ++seams;
    }
  }
  EXPECT_GE(seams, 4);
}

TEST(Placement, ElevationTilesDecodeToTheDemsHeightsAtTheTexelCentres) {
  const fs::path& layer = planeLayer();
  std::size_t texels = 0;
  for (const TileId& tile : test::meshesOnDisk(layer)) {
    const ts::PngImage png = ts::readPng(tileFile(layer, tile, ".elevation.png"));
    ASSERT_EQ(png.width, kTileSize);
    for (int j = 0; j < kTileSize; ++j) {
      for (int i = 0; i < kTileSize; ++i) {
        // Terrarium's published formula.
        const double decoded = png.sample(i, j, 0) * 256.0 + png.sample(i, j, 1) + png.sample(i, j, 2) / 256.0 - 32768;
        const glm::dvec2 at = test::webMercatorTexelLonLat(tile, kTileSize, i, j);
        ASSERT_NEAR(decoded, outputHeight(at.x, at.y), kTerrariumHalfStepM + kHeightRoundingM) << tile.str() << " texel " << i << ", " << j;
        ++texels;
      }
    }
  }
  EXPECT_GE(texels, std::size_t(4) * kTileSize * kTileSize);
}

TEST(Placement, SkirtsHangTheStatedDepthTowardsTheEarthsCentre) {
  const fs::path& layer = planeLayer();
  const json low_poly = json::parse(test::readBytes(layer / "tilejson.json")).at("terrabake").at("low_poly");
  ASSERT_TRUE(low_poly.at("skirts").get<bool>());
  int checked = 0;
  for (const TileId& tile : test::meshesOnDisk(layer)) {
    // The coarser zoom's bound is in the tilejson from the second zoom on.
    if (tile.z == kMinZoom) continue;
    const ts::GlbMesh low = ts::readGlb(tileFile(layer, tile, ".glb"));
    const ts::GlbMesh high = ts::readGlb(tileFile(layer, tile, ".hires.glb"), false);
    const double bound_m = std::max(low_poly.at("max_error_m").at(std::to_string(tile.z)).get<double>(),
                                    low_poly.at("max_error_m").at(std::to_string(tile.z - 1)).get<double>());
    // Two texels: the horizontal distance between the tile's middle samples
    // (texels S / 2 and S / 2 + 1 of row S / 2), in the tile's frame (+Y up).
    const glm::dvec3 step = highResLocalAt(high, kTileSize / 2 + 1, kTileSize / 2) -
                            highResLocalAt(high, kTileSize / 2, kTileSize / 2);
    const double texel_m = std::hypot(step.x, step.z);
    const double depth_m = bound_m + 2 * texel_m;
    // The centre of a sphere of the earth's mean radius touching the
    // ellipsoid under the tile's origin (docs/CONTRACT.md §5), worked out
    // from its lon/lat.
    const double lon = low.origin_lon * M_PI / 180, lat = low.origin_lat * M_PI / 180;
    double x = 0, y = 0, z = 0;
    GeographicLib::Geocentric::WGS84().Forward(low.origin_lat, low.origin_lon, 0, x, y, z);
    const glm::dvec3 up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
    const glm::dvec3 centre = glm::dvec3(x, y, z) - up * test::kMeanEarthRadiusM;
    for (const auto& [copy, border] : skirtCopies(low)) {
      const glm::dvec3 top = ts::localToEcefPoint(low, low.position[border]);
      const glm::dvec3 drop = ts::localToEcefPoint(low, low.position[copy]) - top;
      EXPECT_NEAR(glm::length(drop), depth_m, kFloat32PositionM) << tile.str() << " vertex " << copy;
      // Along the line to that centre: the float32 rounding of both ends, seen from the drop's length.
      EXPECT_LE(test::angleBetweenDeg(drop, centre - top), kFloat32PositionM / depth_m * 180 / M_PI) << tile.str();
      ++checked;
    }
  }
  EXPECT_GE(checked, 4 * 4);
}

// The DEM's extent, clamped to the latitudes Web Mercator reaches.
TEST(Placement, TileJsonBoundsAreTheDemsWithinWebMercatorsLatitudes) {
  const fs::path dir = test::caseDir();
  constexpr double kPolarWest = 10, kPolarNorth = 87, kPolarPixelDeg = 0.05;
  constexpr int kPolarPixels = 60;  // 3 degrees: 84 to 87 N
  ts::writeFloatDem(dir / "polar.tif", 4326, {kPolarWest, kPolarPixelDeg, 0, kPolarNorth, 0, -kPolarPixelDeg},
                    kPolarPixels, kPolarPixels, [](double, double) { return 100.0; });
  config::TileJob job = test::tileJob(dir / "polar.tif", "placement/polar", SchemeKind::kWebMercator, 3, 4);
  job.output_dir = (dir / "out").string();
  job.tile_size = 32;
  job.backend = Backend::kCpu;
  ASSERT_GT(pipeline::runTileJob(job, {}).written, 0);
  const json tilejson = json::parse(test::readBytes(test::layerDir(job) / "tilejson.json"));
  const double max_lat = std::atan(std::sinh(M_PI)) * 180 / M_PI;  // 85.0511...
  const double east = kPolarWest + kPolarPixels * kPolarPixelDeg, south = kPolarNorth - kPolarPixels * kPolarPixelDeg;
  const json& b = tilejson.at("bounds");
  EXPECT_NEAR(b.at(0).get<double>(), kPolarWest, 1e-9);
  EXPECT_NEAR(b.at(1).get<double>(), south, 1e-9);
  EXPECT_NEAR(b.at(2).get<double>(), east, 1e-9);
  EXPECT_NEAR(b.at(3).get<double>(), max_lat, 1e-9);
  const json& c = tilejson.at("center");
  EXPECT_NEAR(c.at(0).get<double>(), (kPolarWest + east) / 2, 1e-9);
  EXPECT_NEAR(c.at(1).get<double>(), (south + max_lat) / 2, 1e-9);
  EXPECT_EQ(c.at(2).get<int>(), 4);
}

// Green down is green up mirrored: g_down = M - g_up, but where g_up rounds
// a value exactly half way, g_down rounds the mirrored half up too.
TEST(Placement, GreenDownStoresMinusY) {
  const fs::path dir = test::caseDir();
  std::map<Green, fs::path> layers;
  for (const Green green : {Green::kUp, Green::kDown}) {
    config::TileJob job = test::tileJob(test::smallDem(), "placement/green", SchemeKind::kWebMercator, 12, 12);
    job.output_dir = (dir / "out").string();
    job.layer = std::string(wordOf(green));
    job.tile_size = 32;
    job.green = green;
    job.backend = Backend::kCpu;
    ASSERT_GT(pipeline::runTileJob(job, {}).written, 0);
    layers[green] = test::layerDir(job);
    EXPECT_EQ(json::parse(test::readBytes(layers[green] / "tilejson.json")).at("terrabake").at("green"),
              std::string(wordOf(green)));
  }
  std::size_t texels = 0, halves = 0;
  for (const TileId& tile : test::meshesOnDisk(layers[Green::kUp])) {
    const ts::PngImage up = ts::readPng(tileFile(layers[Green::kUp], tile, ".png"));
    const ts::PngImage down = ts::readPng(tileFile(layers[Green::kDown], tile, ".png"));
    ASSERT_EQ(up.samples.size(), down.samples.size());
    const int max = (1 << up.bits) - 1;
    for (int j = 0; j < up.height; ++j) {
      for (int i = 0; i < up.width; ++i) {
        ASSERT_EQ(up.sample(i, j, 0), down.sample(i, j, 0)) << tile.str();
        ASSERT_EQ(up.sample(i, j, 2), down.sample(i, j, 2)) << tile.str();
        const int sum = up.sample(i, j, 1) + down.sample(i, j, 1);
        ASSERT_TRUE(sum == max || sum == max + 1) << tile.str() << " texel " << i << ", " << j << ": " << sum;
        halves += sum == max + 1;
        ++texels;
      }
    }
  }
  EXPECT_GE(texels, std::size_t(2) * 32 * 32);
  // Exact halves are rare: float arithmetic lands on one now and then.
  EXPECT_LE(double(halves), 0.001 * double(texels));
}

}  // namespace
}  // namespace terrabake

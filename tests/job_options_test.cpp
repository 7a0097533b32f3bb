// The job options that shape what a run covers and what a tile holds:
// vertical units and exaggeration, `tiling.zoom: auto`, `tiling.bbox`,
// `nodata.max_fill_px` and `output.alpha`, through the config module and
// whole runs of the library.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "bake/encode.hpp"
#include "core/error.hpp"
#include "layer_check.hpp"
#include "pipeline/layer_plan.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;

constexpr double kCentreLon = 15.3, kCentreLat = 60.0;
constexpr double kPixelM = 30.0;
constexpr double kFootM = 0.3048;
// WGS84 equatorial circumference: Web Mercator's world width in metres.
constexpr double kEquatorM = 40075016.685578488;

// --------------------------------------------------------------- fixtures

// Float32 GeoTIFF in UTM 33N (EPSG:32633), north-up, 30 m pixels, centred
// on kCentreLon / kCentreLat; pixel (col, row) holds height(col, row).
void writeDem(const fs::path& path, int width, int height, const std::function<float(int, int)>& heights) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  std::unique_ptr<GDALDataset> ds(driver->Create(path.c_str(), width, height, 1, GDT_Float32, nullptr));
  ASSERT_NE(ds, nullptr) << path;
  const glm::dvec2 centre = ts::utm33(kCentreLon, kCentreLat);
  double gt[6] = {centre.x - width * kPixelM / 2, kPixelM, 0, centre.y + height * kPixelM / 2, 0, -kPixelM};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.importFromEPSG(32633);
  ds->SetSpatialRef(&srs);
  std::vector<float> values(std::size_t(width) * height);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) values[std::size_t(row) * width + col] = heights(col, row);
  }
  ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, width, height, values.data(), width, height,
                                           GDT_Float32, 0, 0),
            CE_None);
}

// The analytic terrain (metres) at the centre of a pixel of writeDem's grid.
double terrainM(int width, int height, int col, int row) {
  const glm::dvec2 centre = ts::utm33(kCentreLon, kCentreLat);
  return ts::heightUtm(centre.x + (col + 0.5 - width / 2.0) * kPixelM,
                       centre.y - (row + 0.5 - height / 2.0) * kPixelM);
}

// The terrain in feet, rounded to 1/64 ft so that every value and its
// product with kFootM are exact in float: the metre DEM then holds exactly
// what terrabake computes from the feet DEM.
float terrainFt(int width, int height, int col, int row) {
  return float(std::round(terrainM(width, height, col, row) / kFootM * 64) / 64);
}

std::map<std::string, std::string> filesOf(const fs::path& layer, const std::string& extension) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(layer)) {
    if (!entry.is_regular_file() || entry.path().extension() != extension) continue;
    files[fs::relative(entry.path(), layer).string()] = test::readBytes(entry.path());
  }
  return files;
}

std::set<std::string> tilesOf(const fs::path& layer) {
  std::set<std::string> tiles;
  for (const auto& [name, bytes] : filesOf(layer, ".png")) tiles.insert(fs::path(name).replace_extension().string());
  return tiles;
}

nlohmann::json tileJsonOf(const fs::path& layer) {
  std::ifstream in(layer / "tilejson.json");
  return nlohmann::json::parse(in);
}

config::TileJob cpuJob(const fs::path& dem, const std::string& out_name, SchemeKind scheme, int min_zoom,
                       int max_zoom) {
  config::TileJob job = test::tileJob(dem, "job_options/" + out_name, scheme, min_zoom, max_zoom);
  job.backend = Backend::kCpu;  // no GL: these tests are about inputs
  return job;
}

// ------------------------------------------------------------ config keys

TEST(JobOptionKeys, ReadFromYamlAndFlags) {
  const fs::path dir = test::testOutput("job_options/keys");
  fs::create_directories(dir);
  const fs::path yaml = dir / "job.yaml";
  std::ofstream(yaml) << "dem: a.tif\n"
                         "output:\n  alpha: true\n"
                         "tiling:\n  zoom: [9, auto]\n  bbox: [9.5, 46.25, 10, 46.75]\n"
                         "heights:\n  z_scale: 0.3048\n  exaggeration: 2.5\n"
                         "nodata:\n  max_fill_px: 0\n";
  config::TileJob job = config::loadTileJob(yaml.string());
  EXPECT_TRUE(job.alpha);
  EXPECT_EQ(job.min_zoom, 9);
  EXPECT_TRUE(job.max_zoom_auto);
  EXPECT_EQ(job.bbox, (std::vector<double>{9.5, 46.25, 10, 46.75}));
  EXPECT_EQ(job.z_scale, 0.3048);
  EXPECT_EQ(job.exaggeration, 2.5);
  EXPECT_EQ(job.max_fill_px, 0);
  EXPECT_NO_THROW(config::validate(job, yaml.string()));

  // Every new key is part of what a layer records about the job that made it.
  const std::string fingerprint = config::layerFingerprint(job);
  for (const char* line : {"output.alpha: true\n", "tiling.zoom: 9-auto\n", "tiling.bbox: [9.5, 46.25, 10, 46.75]\n",
                           "heights.z_scale: 0.3048\n", "heights.exaggeration: 2.5\n", "nodata.max_fill_px: 0\n"}) {
    EXPECT_NE(fingerprint.find(line), std::string::npos) << line << "not in\n" << fingerprint;
  }

  config::applyOverride(job, "tiling.zoom", {"auto"}, "--zoom");
  EXPECT_EQ(job.min_zoom, 0);
  EXPECT_TRUE(job.max_zoom_auto);
  config::applyOverride(job, "tiling.zoom", {"3-auto"}, "--zoom");
  EXPECT_EQ(job.min_zoom, 3);
  EXPECT_TRUE(job.max_zoom_auto);
  config::applyOverride(job, "tiling.zoom", {"3-5"}, "--zoom");
  EXPECT_EQ(job.max_zoom, 5);
  EXPECT_FALSE(job.max_zoom_auto);
  config::applyOverride(job, "tiling.bbox", {"-10.5, 40,5,50"}, "--bbox");
  EXPECT_EQ(job.bbox, (std::vector<double>{-10.5, 40, 5, 50}));
  config::applyOverride(job, "tiling.bbox", {"none"}, "--bbox");
  EXPECT_TRUE(job.bbox.empty());
  config::applyOverride(job, "heights.exaggeration", {"1e1"}, "--exaggeration");
  EXPECT_EQ(job.exaggeration, 10);

  const config::TileJob defaults;
  EXPECT_FALSE(defaults.alpha);
  EXPECT_TRUE(defaults.bbox.empty());
  EXPECT_EQ(defaults.z_scale, 1);
  EXPECT_EQ(defaults.exaggeration, 1);
  EXPECT_EQ(defaults.max_fill_px, 64);
}

TEST(JobOptionKeys, BadValuesNameTheFlagAndKey) {
  const auto message = [](const std::string& key, const std::string& value, const std::string& flag) {
    config::TileJob job;
    try {
      config::applyOverride(job, key, {value}, flag);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("tiling.zoom", "auto-9", "--zoom"),
            "--zoom: tiling.zoom: expected an integer, [min, max], \"min-max\" or auto, got 'auto-9'");
  EXPECT_EQ(message("tiling.zoom", "25-auto", "--zoom"), "--zoom: tiling.zoom: must be between 0 and 24, got 25");
  EXPECT_EQ(message("tiling.bbox", "1,2,3", "--bbox"),
            "--bbox: tiling.bbox: expected [west, south, east, north] in degrees, got 3 values");
  EXPECT_EQ(message("tiling.bbox", "1,2,x,4", "--bbox"), "--bbox: tiling.bbox: expected a number, got 'x'");
  EXPECT_EQ(message("tiling.bbox", "12,46,10,47", "--bbox"), "no error");  // across the antimeridian
  EXPECT_EQ(message("tiling.bbox", "10,46,10,47", "--bbox"),
            "--bbox: tiling.bbox: west and east must differ, got [10, 46, 10, 47]");
  EXPECT_EQ(message("tiling.bbox", "180,46,-180,47", "--bbox"),
            "--bbox: tiling.bbox: west and east must differ, got [180, 46, -180, 47]");
  EXPECT_EQ(message("tiling.bbox", "190,46,12,47", "--bbox"),
            "--bbox: tiling.bbox: longitudes must be between -180 and 180, got [190, 46, 12, 47]");
  EXPECT_EQ(message("tiling.bbox", "10,47,12,46", "--bbox"),
            "--bbox: tiling.bbox: south 47 must be less than north 46");
  EXPECT_EQ(message("tiling.bbox", "10,46,12,91", "--bbox"),
            "--bbox: tiling.bbox: latitudes must be between -90 and 90, got [10, 46, 12, 91]");
  EXPECT_EQ(message("tiling.bbox", "-181,46,12,47", "--bbox"),
            "--bbox: tiling.bbox: longitudes must be between -180 and 180, got [-181, 46, 12, 47]");
  EXPECT_EQ(message("heights.z_scale", "0", "--z-scale"),
            "--z-scale: heights.z_scale: must be above 0 and at most 1000, got 0");
  EXPECT_EQ(message("heights.z_scale", "nan", "--z-scale"), "--z-scale: heights.z_scale: expected a number, got 'nan'");
  EXPECT_EQ(message("heights.exaggeration", "-2", "--exaggeration"),
            "--exaggeration: heights.exaggeration: must be above 0 and at most 100, got -2");
  EXPECT_EQ(message("heights.exaggeration", "200", "--exaggeration"),
            "--exaggeration: heights.exaggeration: must be above 0 and at most 100, got 200");
  EXPECT_EQ(message("nodata.max_fill_px", "513", "--max-fill"),
            "--max-fill: nodata.max_fill_px: must be between 0 and 512, got 513");
  EXPECT_EQ(message("output.alpha", "yes", "--alpha"), "--alpha: output.alpha: expected true or false, got 'yes'");

  // In a file, the message names file and line.
  const fs::path dir = test::testOutput("job_options/bad_keys");
  fs::create_directories(dir);
  const fs::path yaml = dir / "job.yaml";
  std::ofstream(yaml) << "dem: a.tif\ntiling:\n  zoom: 3\n  bbox: [1, 2, 3]\n";
  try {
    config::loadTileJob(yaml.string());
    ADD_FAILURE() << "a bbox of three numbers was accepted";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()),
              yaml.string() + ":4: tiling.bbox: expected [west, south, east, north] in degrees, got 3 values");
  }
}

// --------------------------------------------------------- vertical units

constexpr int kUnitsDemPixels = 128;
constexpr int kUnitsTileSize = 32;  // native level 2: 4 x 4 tiles at full resolution

// Tiles whose apron lies inside the DEM: their heights are exactly the DEM's
// samples, so equal heights must give equal bytes. Tiles at the DEM's edge
// also use heights filled beyond it, from values that are only nearly equal.
bool isInteriorTile(const std::string& tile) {
  return tile == "2/1/1" || tile == "2/1/2" || tile == "2/2/1" || tile == "2/2/2";
}

void expectSameTiles(const fs::path& a, const fs::path& b) {
  for (const char* extension : {".png", ".glb"}) {
    const auto files_a = filesOf(a, extension), files_b = filesOf(b, extension);
    ASSERT_EQ(files_a.size(), 16u) << extension;
    ASSERT_EQ(files_b.size(), files_a.size()) << extension;
    for (const auto& [name, bytes] : files_a) {
      if (!isInteriorTile(fs::path(name).replace_extension().string())) continue;
      EXPECT_TRUE(bytes == files_b.at(name)) << name;
    }
  }
  // Edge tiles: at most one quantisation step apart anywhere.
  for (const auto& [name, bytes] : filesOf(a, ".png")) {
    const auto pa = ts::readPng(a / name), pb = ts::readPng(b / name);
    ASSERT_EQ(pa.samples.size(), pb.samples.size()) << name;
    for (std::size_t k = 0; k < pa.samples.size(); ++k) {
      ASSERT_LE(std::abs(int(pa.samples[k]) - int(pb.samples[k])), 1) << name << " sample " << k;
    }
  }
}

fs::path feetDem() {
  return test::sharedFixture("units_feet.tif", [](const fs::path& path) {
    const int n = kUnitsDemPixels;
    writeDem(path, n, n, [](int c, int r) { return terrainFt(n, n, c, r); });
  });
}

TEST(VerticalUnits, FeetWithZScaleBakeTheBytesOfMetres) {
  const int n = kUnitsDemPixels;
  const fs::path feet = feetDem();
  const fs::path metres = test::sharedFixture("units_metres.tif", [&](const fs::path& path) {
    writeDem(path, n, n, [&](int c, int r) { return float(double(terrainFt(n, n, c, r)) * kFootM); });
  });
  config::TileJob metre_job = cpuJob(metres, "units_metres", SchemeKind::kNative, 2, 2);
  metre_job.tile_size = kUnitsTileSize;
  config::TileJob feet_job = cpuJob(feet, "units_feet", SchemeKind::kNative, 2, 2);
  feet_job.tile_size = kUnitsTileSize;
  feet_job.z_scale = kFootM;
  ASSERT_EQ(pipeline::runTileJob(metre_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(feet_job).failed, 0);
  expectSameTiles(test::layerDir(metre_job), test::layerDir(feet_job));
  EXPECT_EQ(tileJsonOf(test::layerDir(feet_job))["terrabake"]["z_scale"], kFootM);
  EXPECT_EQ(tileJsonOf(test::layerDir(metre_job))["terrabake"]["z_scale"], 1.0);

  // Feet taken as metres is a different, flatter terrain: the test can tell.
  config::TileJob unscaled = feet_job;
  unscaled.z_scale = 1;
  unscaled.output_dir = test::testOutput("job_options/units_unscaled").string();
  ASSERT_EQ(pipeline::runTileJob(unscaled).failed, 0);
  EXPECT_NE(filesOf(test::layerDir(unscaled), ".png"), filesOf(test::layerDir(metre_job), ".png"));
}

TEST(VerticalUnits, ExaggerationScalesHeightsAfterZScale) {
  const int n = kUnitsDemPixels;
  constexpr double kExaggeration = 3;
  const fs::path feet = feetDem();
  const fs::path tall = test::sharedFixture("units_metres_x3.tif", [&](const fs::path& path) {
    writeDem(path, n, n,
             [&](int c, int r) { return float(double(terrainFt(n, n, c, r)) * (kFootM * kExaggeration)); });
  });
  config::TileJob tall_job = cpuJob(tall, "units_tall", SchemeKind::kNative, 2, 2);
  tall_job.tile_size = kUnitsTileSize;
  config::TileJob exaggerated = cpuJob(feet, "units_exaggerated", SchemeKind::kNative, 2, 2);
  exaggerated.tile_size = kUnitsTileSize;
  exaggerated.z_scale = kFootM;
  exaggerated.exaggeration = kExaggeration;
  ASSERT_EQ(pipeline::runTileJob(tall_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(exaggerated).failed, 0);
  expectSameTiles(test::layerDir(tall_job), test::layerDir(exaggerated));
  EXPECT_EQ(tileJsonOf(test::layerDir(exaggerated))["terrabake"]["exaggeration"], kExaggeration);
}

// A plane rising `kSlope` metres per metre eastwards tilts its normal by
// atan(kSlope); exaggerated k times, by atan(k * kSlope). The decoded
// normals must show that, within the 8-bit accuracy bound of the project
// (mean 0.35 degrees) and UTM's scale error (0.04 %).
constexpr double kSlope = 0.1;
constexpr double kMaxTiltErrorDeg = 0.35;

double meanTiltDeg(const config::TileJob& job, const fs::path& dem) {
  const test::DemGeometry geometry(dem);
  const test::DecodedTile tile = test::readTile(test::layerDir(job), {2, 1, 1});
  double sum = 0;
  int count = 0;
  for (int j = 0; j < kUnitsTileSize; ++j) {
    for (int i = 0; i < kUnitsTileSize; ++i) {
      const glm::dvec2 lon_lat =
          geometry.lonLatOfPixel(kUnitsTileSize + i + 0.5, kUnitsTileSize + j + 0.5);  // tile 1 starts at pixel 32
      const auto normal = tile.ecefNormal(i, j);
      EXPECT_TRUE(normal.has_value());
      if (!normal) continue;
      sum += test::angleBetweenDeg(*normal, ts::ellipsoidUpEcef(lon_lat.x, lon_lat.y));
      ++count;
    }
  }
  return sum / count;
}

TEST(VerticalUnits, ExaggerationTiltsNormalsAsExpected) {
  const int n = kUnitsDemPixels;
  const fs::path plane = test::sharedFixture("units_plane.tif", [&](const fs::path& path) {
    writeDem(path, n, n, [&](int c, int) { return float(500 + kSlope * kPixelM * c); });
  });
  for (const double exaggeration : {1.0, 3.0}) {
    config::TileJob job = cpuJob(plane, "plane_x" + std::to_string(int(exaggeration)), SchemeKind::kNative, 2, 2);
    job.tile_size = kUnitsTileSize;
    job.exaggeration = exaggeration;
    ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
    const double expected_deg = std::atan(exaggeration * kSlope) * 180 / M_PI;
    EXPECT_NEAR(meanTiltDeg(job, plane), expected_deg, kMaxTiltErrorDeg) << "exaggeration " << exaggeration;
  }
}

// ------------------------------------------------------------- zoom auto

// The 30 m DEM of the other pipeline tests: 256 x 256 pixels at 60 N.
fs::path dem60North() {
  return test::analyticUtmDem(256);
}

int autoZoom(SchemeKind scheme, int tile_size) {
  config::TileJob job = cpuJob(dem60North(), "unused", scheme, 0, 0);
  job.max_zoom_auto = true;
  job.tile_size = tile_size;
  return pipeline::planLayer(job).max_zoom;
}

TEST(ZoomAuto, WebMercatorPicksTheDeepestZoomWithTexelsNoSmallerThanPixels) {
  // A Web Mercator texel at zoom z spans kEquatorM / (256 * 2^z) metres of
  // the map, cos(lat) of that on the ground: at 60 N, 38.2 m at zoom 11 and
  // 19.1 m at zoom 12. The DEM has 30 m pixels, so zoom 11.
  int expected = 0;
  while (kEquatorM * std::cos(kCentreLat * M_PI / 180) / (256 << (expected + 1)) >= kPixelM) ++expected;
  ASSERT_EQ(expected, 11);
  EXPECT_EQ(autoZoom(SchemeKind::kWebMercator, 256), 11);
  // Tiles half as wide hold texels half as wide: one zoom deeper.
  EXPECT_EQ(autoZoom(SchemeKind::kWebMercator, 128), 12);
}

TEST(ZoomAuto, GeodeticComparesTexelAndPixelByArea) {
  // Geodetic texels at zoom z are 180 / (256 * 2^z) degrees a side: at 60 N,
  // 111.4 km a degree north-south and 55.8 km east-west, so the texel's
  // ground size (root of its area) is 54 m at zoom 10 and 27 m at zoom 11.
  EXPECT_EQ(autoZoom(SchemeKind::kGeodetic, 256), 10);
}

TEST(ZoomAuto, NativeTakesTheFullResolutionLevel) {
  // 256 pixels in 64-texel tiles: levels 0 (one tile) to 2 (full resolution).
  EXPECT_EQ(autoZoom(SchemeKind::kNative, 64), 2);
}

TEST(ZoomAuto, RunsFromMinToTheChosenZoom) {
  config::TileJob job = cpuJob(dem60North(), "auto_run", SchemeKind::kNative, 1, 0);
  job.tile_size = 64;
  job.max_zoom_auto = true;
  const auto summary = pipeline::runTileJob(job);
  EXPECT_EQ(summary.failed, 0);
  EXPECT_EQ(summary.written, 4 + 16);  // levels 1 and 2
  const nlohmann::json tilejson = tileJsonOf(test::layerDir(job));
  EXPECT_EQ(tilejson["minzoom"], 1);
  EXPECT_EQ(tilejson["maxzoom"], 2);

  job.min_zoom = 3;
  try {
    pipeline::planLayer(job);
    ADD_FAILURE() << "min above auto's choice was accepted";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("tiling.zoom: min 3 is above auto's choice, 2", 0), 0u) << e.what();
  }
}

// ------------------------------------------------------------------ bbox

// XYZ tile of a lon/lat point at `zoom` (spherical Web Mercator).
std::pair<int, int> xyzTile(double lon_deg, double lat_deg, int zoom) {
  const double n = std::ldexp(1.0, zoom), lat = lat_deg * M_PI / 180;
  return {int(std::floor((lon_deg + 180) / 360 * n)),
          int(std::floor((1 - std::asinh(std::tan(lat)) / M_PI) / 2 * n))};
}

TEST(Bbox, LimitsTheRunToTilesThatIntersectIt) {
  constexpr int kZoom = 13;
  config::TileJob whole = cpuJob(dem60North(), "bbox_whole", SchemeKind::kWebMercator, kZoom, kZoom);
  whole.tile_size = 64;
  ASSERT_EQ(pipeline::runTileJob(whole).failed, 0);

  // The south-west part of the 7.7 km DEM, away from tile edges.
  const std::vector<double> box = {15.2573, 59.9713, 15.2991, 59.9961};
  config::TileJob part = cpuJob(dem60North(), "bbox_part", SchemeKind::kWebMercator, kZoom, kZoom);
  part.tile_size = 64;
  part.bbox = box;
  ASSERT_EQ(pipeline::runTileJob(part).failed, 0);

  const auto [x0, y0] = xyzTile(box[0], box[3], kZoom);
  const auto [x1, y1] = xyzTile(box[2], box[1], kZoom);
  std::set<std::string> expected;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) expected.insert(TileId{kZoom, x, y}.str());
  }
  const std::set<std::string> written = tilesOf(test::layerDir(part)), all = tilesOf(test::layerDir(whole));
  EXPECT_EQ(written, expected);
  EXPECT_LT(written.size(), all.size());
  // A tile of the box is the tile the whole run made.
  const auto part_files = filesOf(test::layerDir(part), ".png"), whole_files = filesOf(test::layerDir(whole), ".png");
  for (const auto& [name, bytes] : part_files) EXPECT_TRUE(bytes == whole_files.at(name)) << name;
  // tilejson's bounds are the box (it lies inside the DEM).
  const nlohmann::json bounds = tileJsonOf(test::layerDir(part))["bounds"];
  for (int i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(bounds[i].get<double>(), box[i]) << i;
}

// A box with west above east runs across the antimeridian; over a DEM far
// from it, it leaves a piece of the DEM either side of its gap. The layer's
// bounds hold both pieces, west below east; they once ran from the east
// piece round the globe to the west one, centred on the far side of it.
TEST(Bbox, AGapInsideTheDemLeavesBoundsAroundBothSidesOfIt) {
  config::TileJob job = cpuJob(dem60North(), "bbox_gap", SchemeKind::kWebMercator, 10, 10);
  job.bbox = {kCentreLon + 0.01, -80, kCentreLon - 0.01, 80};
  const pipeline::LayerPlan plan = pipeline::planLayer(job);
  const nlohmann::json tilejson = nlohmann::json::parse(plan.tilejson);
  const nlohmann::json& bounds = tilejson.at("bounds");
  EXPECT_LT(bounds[0].get<double>(), kCentreLon - 0.01) << bounds;
  EXPECT_GT(bounds[2].get<double>(), kCentreLon + 0.01) << bounds;
  EXPECT_NEAR(tilejson.at("center")[0].get<double>(), kCentreLon, 0.5) << tilejson.at("center");
}

TEST(Bbox, BesideTheDemMakesNothingNamingTheKey) {
  config::TileJob job = cpuJob(dem60North(), "bbox_beside", SchemeKind::kWebMercator, 10, 10);
  job.bbox = {20, 40, 21, 41};
  try {
    pipeline::planLayer(job);
    ADD_FAILURE() << "a box beside the DEM was accepted";
  } catch (const NothingToMake& e) {
    EXPECT_EQ(std::string(e.what()).rfind("tiling.bbox: lon 20 to 21, lat 40 to 41 does not overlap", 0), 0u)
        << e.what();
    EXPECT_EQ(e.code(), ExitCode::kNothingMade);
  }
}

// ------------------------------------------------------- holes and alpha

constexpr int kHoleDemPixels = 100;  // not a multiple of the tile size: edge tiles reach past the DEM
constexpr int kHoleTileSize = 64;    // native level 1: 2 x 2 tiles at full resolution

bool inHole(int col, int row) { return col >= 20 && col < 45 && row >= 30 && row < 50; }

fs::path demWithHole() {
  return test::sharedFixture("alpha_hole_100.tif", [](const fs::path& path) {
    const int n = kHoleDemPixels;
    writeDem(path, n, n, [](int c, int r) { return inHole(c, r) ? NAN : float(terrainM(n, n, c, r)); });
  });
}

config::TileJob holeJob(const std::string& name) {
  config::TileJob job = cpuJob(demWithHole(), name, SchemeKind::kNative, 1, 1);
  job.tile_size = kHoleTileSize;
  return job;
}

TEST(Alpha, IsZeroExactlyWhereTheDemHasNoSample) {
  config::TileJob opaque = holeJob("alpha_off");
  config::TileJob alpha = holeJob("alpha_on");
  alpha.alpha = true;
  ASSERT_EQ(pipeline::runTileJob(opaque).written, 4);
  ASSERT_EQ(pipeline::runTileJob(alpha).written, 4);
  EXPECT_EQ(tileJsonOf(test::layerDir(alpha))["terrabake"]["alpha"], true);
  EXPECT_EQ(tileJsonOf(test::layerDir(opaque))["terrabake"]["alpha"], false);

  int void_texels = 0;
  for (int ty = 0; ty < 2; ++ty) {
    for (int tx = 0; tx < 2; ++tx) {
      const std::string name = "1/" + std::to_string(tx) + "/" + std::to_string(ty) + ".png";
      const ts::PngImage rgba = ts::readPng(test::layerDir(alpha) / name);
      const ts::PngImage rgb = ts::readPng(test::layerDir(opaque) / name);
      ASSERT_EQ(rgba.channels, 4) << name;
      ASSERT_EQ(rgb.channels, 3) << name;
      for (int j = 0; j < kHoleTileSize; ++j) {
        for (int i = 0; i < kHoleTileSize; ++i) {
          const int col = tx * kHoleTileSize + i, row = ty * kHoleTileSize + j;
          const bool valid = col < kHoleDemPixels && row < kHoleDemPixels && !inHole(col, row);
          void_texels += !valid;
          ASSERT_EQ(rgba.sample(i, j, 3), valid ? 255 : 0) << name << " texel " << i << "," << j;
          // Colour does not depend on alpha: void texels keep their filled normals.
          for (int c = 0; c < 3; ++c) ASSERT_EQ(rgba.sample(i, j, c), rgb.sample(i, j, c)) << name;
        }
      }
    }
  }
  EXPECT_EQ(void_texels, 128 * 128 - 100 * 100 + 25 * 20);
}

TEST(Alpha, SixteenBitAlphaIsFullScale) {
  bake::NormalMap map{2, {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}};
  Raster<std::uint8_t> covered(2, 2, 1);
  covered.at(1, 0) = 0;
  const Image<std::uint16_t> rgba = bake::addAlpha(bake::encodeNormalMap(map, 16, Green::kUp), covered, 16);
  ASSERT_EQ(rgba.channels, 4);
  EXPECT_EQ(rgba.pixels, (std::vector<std::uint16_t>{32768, 32768, 65535, 65535, 32768, 32768, 65535, 0,  //
                                                     32768, 32768, 65535, 65535, 32768, 32768, 65535, 65535}));
}

TEST(MaxFill, ChangesOnlyTilesWhoseWindowHasHoles) {
  // 256 pixels in 64-texel tiles: the hole lies in tile (2, 2) only, and the
  // read of tile (1, 1), apron included, has no void at all.
  const fs::path dem = test::sharedFixture("fill_hole_256.tif", [](const fs::path& path) {
    writeDem(path, 256, 256, [](int c, int r) {
      return c >= 150 && c < 180 && r >= 150 && r < 180 ? NAN : float(terrainM(256, 256, c, r));
    });
  });
  config::TileJob membrane = cpuJob(dem, "fill_64", SchemeKind::kNative, 2, 2);
  membrane.tile_size = 64;
  config::TileJob backdrop = membrane;
  backdrop.output_dir = test::testOutput("job_options/fill_0").string();
  backdrop.max_fill_px = 0;
  ASSERT_EQ(pipeline::runTileJob(membrane).written, 16);
  ASSERT_EQ(pipeline::runTileJob(backdrop).written, 16);
  const auto a = filesOf(test::layerDir(membrane), ".png"), b = filesOf(test::layerDir(backdrop), ".png");
  EXPECT_TRUE(a.at("2/1/1.png") == b.at("2/1/1.png"));
  EXPECT_FALSE(a.at("2/2/2.png") == b.at("2/2/2.png")) << "max_fill_px 0 must take the backdrop in the hole";
}

}  // namespace
}  // namespace terrabake

// Inputs as users give them, through the real executable: paths GDAL opens
// (/vsizip/), many files under the default open-file limit, DEMs stored
// flipped, implausible heights, images and complex rasters, DEMs the job
// cannot use (a whole world at zoom 16, a raster 2^31 pixels wide, a FIFO,
// beyond the scheme's latitudes, across the antimeridian), and jobs that
// make nothing, each with its documented exit code.
#include <gtest/gtest.h>

#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::caseDir;
using test::snapshot;
using test::writeText;

// The documented exit codes (README.md), written out: they are the contract.
constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;
constexpr int kExitInput = 3;
constexpr int kExitTilesFailed = 4;
constexpr int kExitNothingMade = 5;

struct RunResult {
  int exit_code = -1;
  bool timed_out = false;
  double seconds = 0;
  std::string out, err;
};

std::string describe(const RunResult& r) {
  std::ostringstream s;
  s << "exit code " << r.exit_code << (r.timed_out ? " (timed out)" : "") << " after " << r.seconds
    << " s\n--- stdout:\n"
    << r.out << "--- stderr:\n"
    << r.err << "---";
  return s.str();
}

RunResult run(const std::vector<std::string>& args, const test::ChildLimits& limits = {},
              std::chrono::seconds limit = std::chrono::seconds(120)) {
  const auto start = Clock::now();
  test::ChildProcess child(args, limits);
  RunResult r;
  r.exit_code = child.wait(limit);
  r.timed_out = child.timedOut();
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  r.out = child.out();
  r.err = child.err();
  return r;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A smooth terrain of `width` x `height` samples in EPSG:4326 (or `epsg`),
// written with the geotransform `gt`; `height_at(col, row)` in storage order.
void writeDem(const fs::path& path, int width, int height, const double (&gt)[6],
              const std::function<float(int, int)>& height_at, int epsg = 4326, int bands = 1,
              GDALDataType type = GDT_Float32) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  std::unique_ptr<GDALDataset> ds(driver->Create(path.c_str(), width, height, bands, type, nullptr));
  ASSERT_NE(ds, nullptr) << path;
  double transform[6];
  std::copy(gt, gt + 6, transform);
  ds->SetGeoTransform(transform);
  OGRSpatialReference srs;
  srs.importFromEPSG(epsg);
  ds->SetSpatialRef(&srs);
  std::vector<float> values(std::size_t(width) * std::size_t(height));
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) values[std::size_t(r) * std::size_t(width) + std::size_t(c)] = height_at(c, r);
  }
  for (int b = 1; b <= bands; ++b) {
    ASSERT_EQ(ds->GetRasterBand(b)->RasterIO(GF_Write, 0, 0, width, height, values.data(), width, height,
                                             GDT_Float32, 0, 0),
              CE_None);
  }
}

// Hills near 46 N, 10 E: 200 x 200 samples of 0.001 degrees, north-up.
constexpr int kHillPixels = 200;
constexpr double kHillWest = 10.0, kHillNorth = 46.0, kHillPixelDeg = 0.001;

float hill(int col, int row) {
  return float(500 + 80 * std::sin(col / 13.0) * std::cos(row / 17.0) + 0.5 * col);
}

void writeHills(const fs::path& path, const std::function<float(int, int)>& height_at = hill) {
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(path, kHillPixels, kHillPixels, gt, height_at);
}

std::vector<std::string> tileArgs(const fs::path& dem, const fs::path& out, const std::string& layer,
                                  const std::string& zoom = "12") {
  return {"tile", "--dem", dem.string(), "--zoom", zoom, "--out", out.string(), "--layer", layer,
          "--backend", "cpu", "--workers", "2"};
}

// The tiles of a layer, .png and .glb, by name.
std::map<std::string, std::string> tilesOf(const fs::path& layer) {
  std::map<std::string, std::string> tiles;
  for (const auto& [name, bytes] : snapshot(layer)) {
    const std::string ext = fs::path(name).extension().string();
    if (ext == ".png" || ext == ".glb") tiles[name] = bytes;
  }
  return tiles;
}

// The largest difference between two PNGs' samples, channel by channel.
int largestStep(const fs::path& a, const fs::path& b) {
  const auto samples = [](const fs::path& path) {
    std::unique_ptr<GDALDataset> png(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
    std::vector<int> values;
    if (!png) return values;
    const int w = png->GetRasterXSize(), h = png->GetRasterYSize(), bands = png->GetRasterCount();
    values.resize(std::size_t(w) * std::size_t(h) * std::size_t(bands));
    if (png->RasterIO(GF_Read, 0, 0, w, h, values.data(), w, h, GDT_Int32, bands, nullptr, 0, 0, 0) != CE_None) {
      values.clear();
    }
    return values;
  };
  const std::vector<int> va = samples(a), vb = samples(b);
  if (va.empty() || va.size() != vb.size()) return std::numeric_limits<int>::max();
  int largest = 0;
  for (std::size_t k = 0; k < va.size(); ++k) largest = std::max(largest, std::abs(va[k] - vb[k]));
  return largest;
}

// The same tiles, byte for byte; with `png_steps` above 0, normal maps
// within that many steps and meshes of the same names only.
void expectSameTiles(const fs::path& a, const fs::path& b, int png_steps = 0) {
  const auto tiles_a = tilesOf(a), tiles_b = tilesOf(b);
  ASSERT_FALSE(tiles_a.empty()) << a;
  ASSERT_EQ(tiles_a.size(), tiles_b.size());
  for (const auto& [name, bytes] : tiles_a) {
    const auto other = tiles_b.find(name);
    ASSERT_NE(other, tiles_b.end()) << name;
    if (png_steps == 0) {
      EXPECT_TRUE(bytes == other->second) << name << " differs";
    } else if (fs::path(name).extension() == ".png") {
      EXPECT_LE(largestStep(a / name, b / name), png_steps) << name;
    }
  }
}

// ------------------------------------------------------------ paths GDAL opens

TEST(Inputs, DemInsideAZipTilesLikeTheUnzippedFile) {
  const fs::path dir = caseDir();
  writeHills(dir / "dem.tif");
  // The zip written through GDAL's own /vsizip/ writer.
  const std::string bytes = test::readBytes(dir / "dem.tif");
  const std::string zipped = "/vsizip/" + (dir / "dem.zip").string() + "/dem.tif";
  VSILFILE* file = VSIFOpenL(zipped.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  ASSERT_EQ(VSIFWriteL(bytes.data(), 1, bytes.size(), file), bytes.size());
  VSIFCloseL(file);
  fs::remove(dir / "dem.tif.aux.xml");

  const RunResult plain = run(tileArgs(dir / "dem.tif", dir / "out", "plain"));
  ASSERT_EQ(plain.exit_code, kExitOk) << describe(plain);
  // As GDAL users write it, in a config file next to the zip (relative) and as a flag (absolute).
  writeText(dir / "job.yaml", "dem: /vsizip/dem.zip/dem.tif\ntiling:\n  zoom: 12\noutput:\n  dir: out\n  layer: "
                              "zipped\nbake:\n  backend: cpu\n  workers: 2\n");
  const RunResult from_config = run({"tile", "--config", (dir / "job.yaml").string()});
  ASSERT_EQ(from_config.exit_code, kExitOk) << describe(from_config);
  expectSameTiles(dir / "out" / "plain", dir / "out" / "zipped");
  const RunResult from_flag = run(tileArgs(zipped, dir / "out", "zipped_flag"));
  ASSERT_EQ(from_flag.exit_code, kExitOk) << describe(from_flag);
  expectSameTiles(dir / "out" / "plain", dir / "out" / "zipped_flag");

  const RunResult missing = run(tileArgs("/vsizip/" + (dir / "dem.zip").string() + "/nothing.tif", dir / "out", "x"));
  EXPECT_EQ(missing.exit_code, kExitInput) << describe(missing);
  EXPECT_TRUE(contains(missing.err, "no such file")) << describe(missing);
}

// 1,100 files of 8 x 8 samples under one glob, 16 workers, and the default
// limit of 1024 open files: more files than the limit, and every worker
// reads many of them.
TEST(Inputs, ThousandsOfFilesWorkUnderTheDefaultOpenFileLimit) {
  const fs::path dir = caseDir();
  constexpr int kFiles = 1100, kSide = 34, kPixels = 8;
  constexpr double kPixelDeg = 0.002;
  fs::create_directories(dir / "dems");
  for (int i = 0; i < kFiles; ++i) {
    const int r = i / kSide, c = i % kSide;
    const double gt[6] = {10 + c * kPixels * kPixelDeg, kPixelDeg, 0, 46 - r * kPixels * kPixelDeg, 0, -kPixelDeg};
    char name[32];
    std::snprintf(name, sizeof name, "t%05d.tif", i);
    writeDem(dir / "dems" / name, kPixels, kPixels, gt, [&](int col, int row) {
      return float(300 + 20 * std::sin((c * kPixels + col) / 9.0) + 10 * std::cos((r * kPixels + row) / 7.0));
    });
    if (HasFatalFailure()) return;
  }
  std::vector<std::string> args = tileArgs(dir / "dems" / "*.tif", dir / "out", "many", "11");
  args.back() = "16";  // workers
  test::ChildLimits limits;
  limits.open_files = 1024;
  const RunResult r = run(args, limits);
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_FALSE(contains(r.err, "Too many open files")) << describe(r);
  EXPECT_GE(tilesOf(dir / "out" / "many").size(), 2u * 16) << describe(r);
}

// ------------------------------------------------------ work bounded by the job

// A whole world of 0.1 degree samples: 3600 x 1800.
fs::path worldDem() {
  return test::sharedFixture("world_3600x1800.tif", [](const fs::path& path) {
    const double gt[6] = {-180, 0.1, 0, 90, 0, -0.1};
    writeDem(path, 3600, 1800, gt, [](int c, int r) { return float(1000 * std::sin(c / 180.0) * std::cos(r / 90.0)); });
  });
}

TEST(Inputs, WorldDemTilesAHundredMetreBoxAtZoom16Quickly) {
  const fs::path dir = caseDir();
  test::ChildLimits limits;
  limits.address_space = std::size_t(3) << 30;
  std::vector<std::string> args = tileArgs(worldDem(), dir / "out", "world", "16");
  args.insert(args.end(), {"--bbox", "10,45,10.0009,45.0009"});
  const RunResult r = run(args, limits);
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_LT(r.seconds, 20 * test::kSanitizerSlowdown) << describe(r);
  EXPECT_EQ(tilesOf(dir / "out" / "world").size(), 2u) << "one tile: .png and .glb\n" << describe(r);
}

// A box across the antimeridian (west above east) makes the tiles of both
// sides, the bytes a box on each side makes, and its tilejson bounds run
// west > east as a DEM across it does; the log says how the box was read.
TEST(Inputs, ABoxAcrossTheAntimeridianMakesTheTilesOfBothSides) {
  const fs::path dir = caseDir();
  const auto runBox = [&](const std::string& layer, const std::string& box) {
    std::vector<std::string> args = tileArgs(worldDem(), dir / "out", layer, "10");
    args.insert(args.end(), {"--bbox", box});
    const RunResult r = run(args);
    EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
    EXPECT_EQ(contains(r.err, "the box runs across the antimeridian: lon 179.8 to 180, lat -0.2 to 0.2 and "
                              "lon -180 to -179.8, lat -0.2 to 0.2"),
              layer == "across")
        << describe(r);
    return tilesOf(dir / "out" / layer);
  };
  const auto across = runBox("across", "179.8,-0.2,-179.8,0.2");
  auto sides = runBox("east", "179.8,-0.2,180,0.2");
  for (const auto& tile : runBox("west", "-180,-0.2,-179.8,0.2")) sides.insert(tile);
  EXPECT_EQ(across.size(), 2u * 4) << "two tile columns a side of the equator, each side";
  EXPECT_EQ(across, sides);
  const std::string text = test::readBytes(dir / "out" / "across" / "tilejson.json");
  EXPECT_TRUE(contains(text, "\"bounds\": [\n    179.8,\n    -0.2,\n    -179.8,")) << text;
}

TEST(Inputs, WorldDemAtZoom16WithoutABoxIsRefusedAtOnceWithItsTileCount) {
  const fs::path dir = caseDir();
  const fs::path dem = worldDem();
  test::ChildLimits limits;
  limits.address_space = std::size_t(3) << 30;
  const RunResult r = run(tileArgs(dem, dir / "out", "world", "16"), limits);
  EXPECT_EQ(r.exit_code, kExitUsage) << describe(r);
  EXPECT_TRUE(contains(r.err, "4294967296 tiles")) << describe(r);
  EXPECT_TRUE(contains(r.err, "--bbox")) << describe(r);
  EXPECT_LT(r.seconds, 5 * test::kSanitizerSlowdown) << describe(r);
  EXPECT_FALSE(fs::exists(dir / "out" / "world" / "16")) << describe(r);
}

TEST(Inputs, VrtTwoToTheThirtyOnePixelsWideIsRefusedFast) {
  const fs::path dir = caseDir();
  writeHills(dir / "dem.tif");
  writeText(dir / "wide.vrt",
            "<VRTDataset rasterXSize=\"2147483647\" rasterYSize=\"4\">\n"
            "  <SRS>EPSG:4326</SRS>\n"
            "  <GeoTransform>-180, 1e-7, 0, 46, 0, -0.001</GeoTransform>\n"
            "  <VRTRasterBand dataType=\"Float32\" band=\"1\">\n"
            "    <SimpleSource><SourceFilename relativeToVRT=\"1\">dem.tif</SourceFilename>"
            "<SourceBand>1</SourceBand></SimpleSource>\n"
            "  </VRTRasterBand>\n</VRTDataset>\n");
  test::ChildLimits limits;
  limits.address_space = std::size_t(3) << 30;
  const RunResult r = run(tileArgs(dir / "wide.vrt", dir / "out", "wide", "3"), limits, std::chrono::seconds(60));
  EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
  EXPECT_TRUE(contains(r.err, "2147483647 x 4 pixels")) << describe(r);
  EXPECT_LT(r.seconds, 5 * test::kSanitizerSlowdown) << describe(r);
}

TEST(Inputs, FifoAsDemOrConfigIsRefusedAtOnce) {
  const fs::path dir = caseDir();
  const fs::path fifo = dir / "pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const RunResult dem = run(tileArgs(fifo, dir / "out", "fifo"), {}, std::chrono::seconds(10));
  EXPECT_EQ(dem.exit_code, kExitInput) << describe(dem);
  EXPECT_TRUE(contains(dem.err, "FIFO")) << describe(dem);
  EXPECT_LT(dem.seconds, 5 * test::kSanitizerSlowdown) << describe(dem);
  const RunResult config = run({"tile", "--config", fifo.string()}, {}, std::chrono::seconds(10));
  EXPECT_EQ(config.exit_code, kExitInput) << describe(config);
  EXPECT_TRUE(contains(config.err, "FIFO")) << describe(config);
  EXPECT_LT(config.seconds, 5 * test::kSanitizerSlowdown) << describe(config);
  const RunResult device = run({"tile", "--config", "/dev/zero"}, {}, std::chrono::seconds(10));
  EXPECT_EQ(device.exit_code, kExitInput) << describe(device);
  EXPECT_TRUE(contains(device.err, "character device")) << describe(device);
}

// A VRT opens its sources with it: a FIFO among them, named relative to the
// VRT or in a VRT the VRT names, is refused as the DEM itself would be.
TEST(Inputs, FifoAmongAVrtsSourcesIsRefusedAtOnce) {
  const fs::path dir = caseDir();
  writeHills(dir / "dem.tif");
  ASSERT_EQ(::mkfifo((dir / "pipe").c_str(), 0600), 0);
  // A VRT of the DEM, its source then swapped for another.
  const auto vrtOf = [&](const std::string& name, const std::string& source) {
    std::unique_ptr<GDALDataset> dem(GDALDataset::Open((dir / "dem.tif").c_str(), GDAL_OF_RASTER));
    ASSERT_NE(dem, nullptr);
    GDALDriver* vrt = GetGDALDriverManager()->GetDriverByName("VRT");
    std::unique_ptr<GDALDataset> copy(vrt->CreateCopy((dir / name).c_str(), dem.get(), FALSE, nullptr, nullptr, nullptr));
    ASSERT_NE(copy, nullptr);
    copy.reset();
    std::string text = test::readBytes(dir / name);
    const std::string from = ">dem.tif<";
    ASSERT_NE(text.find(from), std::string::npos) << text;
    text.replace(text.find(from), from.size(), ">" + source + "<");
    writeText(dir / name, text);
  };
  vrtOf("inner.vrt", "pipe");
  vrtOf("outer.vrt", "inner.vrt");
  vrtOf("absolute.vrt", (dir / "pipe").string());
  vrtOf("plain.vrt", "dem.tif");
  for (const std::string name : {"inner.vrt", "outer.vrt", "absolute.vrt"}) {
    const RunResult r = run(tileArgs(dir / name, dir / "out", "fifo"), {}, std::chrono::seconds(10));
    EXPECT_EQ(r.exit_code, kExitInput) << name << "\n" << describe(r);
    EXPECT_TRUE(contains(r.err, "'" + (dir / "pipe").string() + "': it is a FIFO")) << name << "\n" << describe(r);
    EXPECT_LT(r.seconds, 5 * test::kSanitizerSlowdown) << describe(r);
  }
  const RunResult plain = run(tileArgs(dir / "plain.vrt", dir / "out", "plain"));
  EXPECT_EQ(plain.exit_code, kExitOk) << describe(plain);
}

// ------------------------------------------------------------ garbage refused

TEST(Inputs, FlippedDemsGiveTheTilesOfTheNorthUpOne) {
  const fs::path dir = caseDir();
  writeHills(dir / "north_up.tif");
  const int n = kHillPixels;
  const double south = kHillNorth - n * kHillPixelDeg, east = kHillWest + n * kHillPixelDeg;
  const double south_up[6] = {kHillWest, kHillPixelDeg, 0, south, 0, kHillPixelDeg};
  writeDem(dir / "south_up.tif", n, n, south_up, [&](int c, int r) { return hill(c, n - 1 - r); });
  const double east_west[6] = {east, -kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "east_west.tif", n, n, east_west, [&](int c, int r) { return hill(n - 1 - c, r); });
  const double both[6] = {east, -kHillPixelDeg, 0, south, 0, kHillPixelDeg};
  writeDem(dir / "both.tif", n, n, both, [&](int c, int r) { return hill(n - 1 - c, n - 1 - r); });
  for (const std::string name : {"north_up", "south_up", "east_west", "both"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name, "11-12"));
    ASSERT_EQ(r.exit_code, kExitOk) << name << "\n" << describe(r);
  }
  for (const std::string name : {"south_up", "east_west", "both"}) {
    SCOPED_TRACE(name);
    expectSameTiles(dir / "out" / "north_up", dir / "out" / name);
  }
}

// --dem given again adds a file, as a list in the job file does: the first on top.
TEST(Inputs, RepeatedDemFlagsMergeLikeAListInTheJobFile) {
  const fs::path dir = caseDir();
  constexpr int kHalf = kHillPixels / 2;
  const double west[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "west.tif", kHalf, kHillPixels, west, hill);
  const double east[6] = {kHillWest + kHalf * kHillPixelDeg, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "east.tif", kHalf, kHillPixels, east, [](int c, int r) { return hill(c + kHalf, r); });
  std::vector<std::string> flags = tileArgs(dir / "west.tif", dir / "out", "flags");
  flags.insert(flags.end(), {"--dem", (dir / "east.tif").string()});
  const RunResult by_flags = run(flags);
  ASSERT_EQ(by_flags.exit_code, kExitOk) << describe(by_flags);
  writeText(dir / "job.yaml", "dem: [west.tif, east.tif]\ntiling:\n  zoom: 12\noutput:\n  dir: out\n  layer: file\n"
                              "bake:\n  backend: cpu\n  workers: 2\n");
  const RunResult by_file = run({"tile", "--config", (dir / "job.yaml").string()});
  ASSERT_EQ(by_file.exit_code, kExitOk) << describe(by_file);
  expectSameTiles(dir / "out" / "file", dir / "out" / "flags");
  std::ifstream job(dir / "out" / "flags" / "terrabake-job.txt");
  std::string first_line;
  std::getline(job, first_line);
  EXPECT_EQ(first_line, "dem: [" + (dir / "west.tif").string() + ", " + (dir / "east.tif").string() + "]");
}

// Many DEMs store heights as integers with the band's scale and offset
// (Int16 decimetres: 0.1); the heights are samples * scale + offset.
TEST(Inputs, ScaledSamplesAreReadAsTheHeightsTheyStandFor) {
  const fs::path dir = caseDir();
  constexpr double kScale = 0.1, kOffset = 500;
  constexpr float kNoData = 32767;
  // Big enough for the reduced levels of the coarse zooms, read at every zoom.
  constexpr int kSide = 1024;
  const auto in_hole = [](int c, int r) { return c >= 60 && c < 80 && r >= 90 && r < 110; };
  const auto sample = [&](int c, int r) { return in_hole(c, r) ? kNoData : std::round((hill(c, r) - kOffset) / kScale); };
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "scaled.tif", kSide, kSide, gt, sample, 4326, 1, GDT_Int16);
  {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open((dir / "scaled.tif").c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_NE(ds, nullptr);
    GDALRasterBand* band = ds->GetRasterBand(1);
    ASSERT_EQ(band->SetScale(kScale), CE_None);
    ASSERT_EQ(band->SetOffset(kOffset), CE_None);
    ASSERT_EQ(band->SetNoDataValue(kNoData), CE_None);
  }
  writeDem(dir / "metres.tif", kSide, kSide, gt, [&](int c, int r) {
    return in_hole(c, r) ? NAN : float(sample(c, r) * kScale + kOffset);
  });
  for (const std::string name : {"scaled", "metres"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name, "5-10"));
    ASSERT_EQ(r.exit_code, kExitOk) << name << "\n" << describe(r);
    EXPECT_TRUE(contains(r.err, "reduced levels")) << describe(r);
  }
  expectSameTiles(dir / "out" / "metres", dir / "out" / "scaled");
  const RunResult info = run({"info", (dir / "scaled.tif").string()});
  EXPECT_TRUE(contains(info.out, "heights    samples x 0.1 + 500 (the band's scale and offset)")) << describe(info);
}

// Overwrites band `band` of a GTiff with `value_at(col, row)`; `alpha`: marks it an alpha band.
void writeBand(const fs::path& path, int band, const std::function<float(int, int)>& value_at, bool alpha = false) {
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
  ASSERT_NE(ds, nullptr) << path;
  const int width = ds->GetRasterXSize(), height = ds->GetRasterYSize();
  std::vector<float> values(std::size_t(width) * std::size_t(height));
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) values[std::size_t(r) * std::size_t(width) + std::size_t(c)] = value_at(c, r);
  }
  GDALRasterBand* b = ds->GetRasterBand(band);
  ASSERT_EQ(b->RasterIO(GF_Write, 0, 0, width, height, values.data(), width, height, GDT_Float32, 0, 0), CE_None);
  if (alpha) {
    ASSERT_EQ(b->SetColorInterpretation(GCI_AlphaBand), CE_None);
  }
}

// Files that mark their voids by a mask keep whatever height underneath:
// gdalwarp -dstalpha writes 0 beside a Float32 alpha of 0 (an alpha GDAL's
// own masks do not know), TIFFs carry masks of their own. Those samples are
// voids, as NaN is, in every read and reduced level, flipped or not.
TEST(Inputs, MaskedSamplesAreVoidsWhateverHeightTheyHold) {
  const fs::path dir = caseDir();
  // Big enough for the reduced levels of the coarse zooms, read at every zoom.
  constexpr int kSide = 1024;
  const auto no_data = [](int c, int r) { return c >= 900 || (c >= 60 && c < 80 && r >= 90 && r < 110); };
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "nan.tif", kSide, kSide, gt, [&](int c, int r) { return no_data(c, r) ? NAN : hill(c, r); });
  const auto zero_outside = [&](int c, int r) { return no_data(c, r) ? 0.0f : hill(c, r); };
  const auto opacity = [&](int c, int r) { return no_data(c, r) ? 0.0f : 255.0f; };
  writeDem(dir / "alpha.tif", kSide, kSide, gt, zero_outside, 4326, 2);
  writeBand(dir / "alpha.tif", 2, opacity, true);
  const double south = kHillNorth - kSide * kHillPixelDeg;
  const double south_up[6] = {kHillWest, kHillPixelDeg, 0, south, 0, kHillPixelDeg};
  const auto flipped = [&](const std::function<float(int, int)>& f) {
    return [=](int c, int r) { return f(c, kSide - 1 - r); };
  };
  writeDem(dir / "alpha_south_up.tif", kSide, kSide, south_up, flipped(zero_outside), 4326, 2);
  writeBand(dir / "alpha_south_up.tif", 2, flipped(opacity), true);
  writeDem(dir / "mask.tif", kSide, kSide, gt, zero_outside);
  {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open((dir / "mask.tif").c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_NE(ds, nullptr);
    ASSERT_EQ(ds->CreateMaskBand(GMF_PER_DATASET), CE_None);
    std::vector<GByte> mask(std::size_t(kSide) * kSide);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) mask[std::size_t(r) * kSide + std::size_t(c)] = no_data(c, r) ? 0 : 255;
    }
    ASSERT_EQ(ds->GetRasterBand(1)->GetMaskBand()->RasterIO(GF_Write, 0, 0, kSide, kSide, mask.data(), kSide, kSide,
                                                           GDT_Byte, 0, 0),
              CE_None);
  }
  for (const std::string name : {"nan", "alpha", "alpha_south_up", "mask"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name, "5-10"));
    ASSERT_EQ(r.exit_code, kExitOk) << name << "\n" << describe(r);
    EXPECT_FALSE(contains(r.err, "bands")) << describe(r);  // the alpha band is no second band of heights
  }
  for (const std::string name : {"alpha", "alpha_south_up", "mask"}) {
    SCOPED_TRACE(name);
    expectSameTiles(dir / "out" / "nan", dir / "out" / name);
  }
  const RunResult info = run({"info", (dir / "alpha.tif").string()});
  EXPECT_TRUE(contains(info.out, "mask       band 2 (alpha): no data where it is 0")) << describe(info);
}

// The coarse zooms of a file without overviews read its reduced levels,
// which hold the heights band alone, whichever band that is.
TEST(Inputs, HeightsOfASecondBandAreReadAtEveryZoom) {
  const fs::path dir = caseDir();
  constexpr int kSide = 1024;
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "first.tif", kSide, kSide, gt, hill);
  writeDem(dir / "second.tif", kSide, kSide, gt, [](int, int) { return 7.0f; }, 4326, 2);
  writeBand(dir / "second.tif", 2, hill);
  const RunResult first = run(tileArgs(dir / "first.tif", dir / "out", "first", "5-10"));
  ASSERT_EQ(first.exit_code, kExitOk) << describe(first);
  std::vector<std::string> args = tileArgs(dir / "second.tif", dir / "out", "second", "5-10");
  args.insert(args.end(), {"--band", "2"});
  const RunResult second = run(args);
  ASSERT_EQ(second.exit_code, kExitOk) << describe(second);
  EXPECT_TRUE(contains(second.err, "reduced levels")) << describe(second);
  expectSameTiles(dir / "out" / "first", dir / "out" / "second");
}

// The backdrop that holes are filled from is made when a tile first has
// one, so a run of zooms as fine as the DEM's pixels whose tiles have no
// hole makes no reduced levels (a whole read of the file), and its tiles
// are those of a run that makes them; a tile at the DEM's edge has holes,
// and its run makes them for the backdrop.
TEST(Inputs, ARunOfFineZoomsWithoutHolesMakesNoReducedLevels) {
  const fs::path dir = caseDir();
  constexpr int kSide = 1024;
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "hills.tif", kSide, kSide, gt, hill);
  const auto tiled = [&](const std::string& layer, const std::string& zoom, const std::string& bbox) {
    std::vector<std::string> args = tileArgs(dir / "hills.tif", dir / "out", layer, zoom);
    args.insert(args.end(), {"--bbox", bbox});
    return run(args);
  };
  const RunResult fine = tiled("fine", "10", "10.4,45.4,10.45,45.45");
  ASSERT_EQ(fine.exit_code, kExitOk) << describe(fine);
  EXPECT_FALSE(contains(fine.err, "reduced levels")) << describe(fine);
  const RunResult coarse = tiled("coarse", "5-10", "10.4,45.4,10.45,45.45");
  ASSERT_EQ(coarse.exit_code, kExitOk) << describe(coarse);
  EXPECT_TRUE(contains(coarse.err, "reduced levels")) << describe(coarse);
  const auto fine_tiles = tilesOf(dir / "out" / "fine"), coarse_tiles = tilesOf(dir / "out" / "coarse");
  ASSERT_FALSE(fine_tiles.empty());
  for (const auto& [name, bytes] : fine_tiles) {
    const auto other = coarse_tiles.find(name);
    ASSERT_NE(other, coarse_tiles.end()) << name;
    EXPECT_TRUE(bytes == other->second) << name << " differs";
  }
  const RunResult edge = tiled("edge", "10", "9.99,45.4,10.05,45.45");
  ASSERT_EQ(edge.exit_code, kExitOk) << describe(edge);
  EXPECT_TRUE(contains(edge.err, "reduced levels")) << describe(edge);
}

TEST(Inputs, HeightsInFeetAreWarnedAboutUntilZScaleIsSet) {
  const fs::path dir = caseDir();
  writeHills(dir / "feet.tif");
  {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open((dir / "feet.tif").c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_NE(ds, nullptr);
    ASSERT_EQ(ds->GetRasterBand(1)->SetUnitType("ft"), CE_None);
  }
  const RunResult as_metres = run(tileArgs(dir / "feet.tif", dir / "out", "as_metres"));
  ASSERT_EQ(as_metres.exit_code, kExitOk) << describe(as_metres);
  EXPECT_TRUE(contains(as_metres.err, "warning: dem: band 1 of '" + (dir / "feet.tif").string() +
                                          "' gives its heights in 'ft', which are read as metres: set "
                                          "heights.z_scale (--z-scale) to 0.3048"))
      << describe(as_metres);
  std::vector<std::string> args = tileArgs(dir / "feet.tif", dir / "out", "feet");
  args.insert(args.end(), {"--z-scale", "0.3048"});
  const RunResult feet = run(args);
  ASSERT_EQ(feet.exit_code, kExitOk) << describe(feet);
  EXPECT_FALSE(contains(feet.err, "warning")) << describe(feet);
  // A CRS of feet (New York's state plane) says nothing of the heights, but
  // they are mostly feet too.
  const double state_plane[6] = {980000, 10, 0, 200000, 0, -10};
  writeDem(dir / "state_plane.tif", 100, 100, state_plane, hill, 2263);
  const RunResult info = run({"info", (dir / "state_plane.tif").string()});
  EXPECT_TRUE(contains(info.err, "is in a CRS measured in US survey foot and does not say what its heights are in; "
                                 "they are read as metres: if they are feet too, set heights.z_scale (--z-scale) "
                                 "to 0.3048006096"))
      << describe(info);
  // Units spelt other ways: decimetres get their factor, metres with a space none.
  for (const auto& [unit, factor] :
       {std::pair<std::string, std::string>{"decimetre", "0.1"}, {"km", "1000"}, {"meter ", ""}}) {
    writeHills(dir / "unit.tif");
    {
      std::unique_ptr<GDALDataset> ds(GDALDataset::Open((dir / "unit.tif").c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
      ASSERT_NE(ds, nullptr);
      ASSERT_EQ(ds->GetRasterBand(1)->SetUnitType(unit.c_str()), CE_None);
    }
    const RunResult r = run({"info", (dir / "unit.tif").string()});
    if (factor.empty()) {
      EXPECT_FALSE(contains(r.err, "warning")) << unit << "\n" << describe(r);
    } else {
      EXPECT_TRUE(contains(r.err, "set heights.z_scale (--z-scale) to " + factor)) << unit << "\n" << describe(r);
    }
  }
}

TEST(Inputs, ADemPlacedByControlPointsIsRefusedSayingSo) {
  const fs::path dir = caseDir();
  {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    std::unique_ptr<GDALDataset> ds(driver->Create((dir / "gcps.tif").c_str(), 20, 20, 1, GDT_Float32, nullptr));
    ASSERT_NE(ds, nullptr);
    OGRSpatialReference wgs84;
    wgs84.importFromEPSG(4326);
    GDAL_GCP gcps[3];
    GDALInitGCPs(3, gcps);
    const double at[3][4] = {{0, 0, 10, 46}, {20, 0, 10.02, 46}, {0, 20, 10, 45.98}};  // pixel, line, lon, lat
    for (int k = 0; k < 3; ++k) {
      gcps[k].dfGCPPixel = at[k][0], gcps[k].dfGCPLine = at[k][1], gcps[k].dfGCPX = at[k][2], gcps[k].dfGCPY = at[k][3];
    }
    ASSERT_EQ(ds->SetGCPs(3, gcps, &wgs84), CE_None);
    GDALDeinitGCPs(3, gcps);
  }
  const RunResult r = run(tileArgs(dir / "gcps.tif", dir / "out", "gcps"));
  EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
  EXPECT_TRUE(contains(r.err, "is placed by 3 ground control points, not a geotransform (warp it first")) << describe(r);
}

// GeoPackage, netCDF and HDF files hold their rasters as subdatasets, each
// opened by a name gdalinfo lists.
TEST(Inputs, AContainersRastersAreTiledByTheirSubdatasetNames) {
  const fs::path dir = caseDir();
  writeHills(dir / "hills.tif");
  const fs::path container = dir / "dems.gpkg";
  for (const char* table : {"first", "second"}) {
    std::unique_ptr<GDALDataset> source(GDALDataset::Open((dir / "hills.tif").c_str(), GDAL_OF_RASTER));
    ASSERT_NE(source, nullptr);
    const std::string table_option = std::string("RASTER_TABLE=") + table;
    const char* options[] = {table_option.c_str(), fs::exists(container) ? "APPEND_SUBDATASET=YES" : nullptr, nullptr};
    GDALDriver* gpkg = GetGDALDriverManager()->GetDriverByName("GPKG");
    ASSERT_NE(gpkg, nullptr);
    std::unique_ptr<GDALDataset> copy(gpkg->CreateCopy(container.c_str(), source.get(), FALSE,
                                                       const_cast<char**>(options), nullptr, nullptr));
    ASSERT_NE(copy, nullptr) << table;
  }
  const RunResult whole = run(tileArgs(container, dir / "out", "whole"));
  EXPECT_EQ(whole.exit_code, kExitInput) << describe(whole);
  EXPECT_TRUE(contains(whole.err, "holds 2 rasters as subdatasets; give one as the DEM, e.g. 'GPKG:" +
                                      container.string() + ":first'"))
      << describe(whole);
  const RunResult second = run(tileArgs("GPKG:" + container.string() + ":second", dir / "out", "second"));
  ASSERT_EQ(second.exit_code, kExitOk) << describe(second);
  const RunResult plain = run(tileArgs(dir / "hills.tif", dir / "out", "plain"));
  ASSERT_EQ(plain.exit_code, kExitOk) << describe(plain);
  EXPECT_FALSE(tilesOf(dir / "out" / "second").empty());
  EXPECT_EQ(tilesOf(dir / "out" / "second").size(), tilesOf(dir / "out" / "plain").size());
}

TEST(Inputs, RotatedDemIsRefusedByNameButNotForRoundingNoise) {
  const fs::path dir = caseDir();
  const double rotated[6] = {kHillWest, kHillPixelDeg, 0.0001, kHillNorth, 0.0001, -kHillPixelDeg};
  writeDem(dir / "rotated.tif", 50, 50, rotated, hill);
  const RunResult r = run(tileArgs(dir / "rotated.tif", dir / "out", "rotated"));
  EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
  EXPECT_TRUE(contains(r.err, "rotated")) << describe(r);
  // Rotation terms of rounding noise turn the grid by nothing: read north-up.
  const double north_up[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  const double noise[6] = {kHillWest, kHillPixelDeg, 1e-15, kHillNorth, -1e-15, -kHillPixelDeg};
  writeDem(dir / "north_up.tif", 50, 50, north_up, hill);
  writeDem(dir / "noise.tif", 50, 50, noise, hill);
  for (const std::string name : {"north_up", "noise"}) {
    const RunResult read = run(tileArgs(dir / (name + ".tif"), dir / "out", name));
    ASSERT_EQ(read.exit_code, kExitOk) << describe(read);
  }
  expectSameTiles(dir / "out" / "north_up", dir / "out" / "noise");
}

TEST(Inputs, ImplausibleHeightsAreVoidsWithAWarning) {
  const fs::path dir = caseDir();
  const auto in_block = [](int c, int r) { return c >= 60 && c < 80 && r >= 90 && r < 110; };
  writeHills(dir / "nan.tif", [&](int c, int r) { return in_block(c, r) ? NAN : hill(c, r); });
  const RunResult nan = run(tileArgs(dir / "nan.tif", dir / "out", "nan"));
  ASSERT_EQ(nan.exit_code, kExitOk) << describe(nan);
  EXPECT_FALSE(contains(nan.err, "warning")) << describe(nan);
  // Undeclared fill values far above or below any terrain, the lowest float
  // among them, are voids exactly like NaN (no normal leans on them), and a
  // warning says the file holds them.
  const std::pair<std::string, float> fills[] = {
      {"huge", 1e30f}, {"deep", -1e30f}, {"lowest", std::numeric_limits<float>::lowest()}};
  for (const auto& [name, fill] : fills) {
    const fs::path dem = dir / (name + ".tif");
    writeHills(dem, [&, fill = fill](int c, int r) { return in_block(c, r) ? fill : hill(c, r); });
    const RunResult filled = run(tileArgs(dem, dir / "out", name));
    ASSERT_EQ(filled.exit_code, kExitOk) << describe(filled);
    EXPECT_TRUE(contains(filled.err, "warning: dem: '" + dem.string() + "' holds heights")) << describe(filled);
    EXPECT_TRUE(contains(filled.err, "treated as voids")) << describe(filled);
    expectSameTiles(dir / "out" / "nan", dir / "out" / name);
  }
}

// GIS exports fill with -9999 and often leave the nodata tag out; a file
// that declares its nodata value is taken at its word.
TEST(Inputs, AnUndeclaredFillValueIsAVoidUnlessTheFileDeclaresItsNodata) {
  const fs::path dir = caseDir();
  const auto in_block = [](int c, int r) { return c >= 60 && c < 80 && r >= 90 && r < 110; };
  writeHills(dir / "nan.tif", [&](int c, int r) { return in_block(c, r) ? NAN : hill(c, r); });
  const auto filled = [&](int c, int r) { return in_block(c, r) ? -9999.0f : hill(c, r); };
  writeHills(dir / "fill.tif", filled);
  writeHills(dir / "declared.tif", filled);
  // NaN as the nodata value says no more than Float32 itself does.
  writeHills(dir / "nan_declared.tif", filled);
  for (const auto& [name, nodata] : {std::pair<std::string, double>{"declared", -32768}, {"nan_declared", NAN}}) {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open((dir / (name + ".tif")).c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_NE(ds, nullptr);
    ASSERT_EQ(ds->GetRasterBand(1)->SetNoDataValue(nodata), CE_None);
  }
  for (const std::string name : {"nan", "fill", "declared", "nan_declared"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name));
    ASSERT_EQ(r.exit_code, kExitOk) << name << "\n" << describe(r);
    EXPECT_EQ(contains(r.err, "or -9999, a fill value (it declares no nodata): "), name == "fill") << describe(r);
    EXPECT_EQ(contains(r.err, "or -9999, a fill value (its nodata is NaN): "), name == "nan_declared") << describe(r);
  }
  expectSameTiles(dir / "out" / "nan", dir / "out" / "fill");
  expectSameTiles(dir / "out" / "nan", dir / "out" / "nan_declared");
  EXPECT_NE(tilesOf(dir / "out" / "nan"), tilesOf(dir / "out" / "declared"));
}

// A declared nodata value marks the samples that hold it as they are read:
// 0.1 declared by a Float64 file is no float, nor is 2147483647 by an Int32
// one, and -1e300 lies beyond the floats. No warning calls them implausible.
TEST(Inputs, ADeclaredNodataValueMarksItsSamplesWhateverTheBandsType) {
  const fs::path dir = caseDir();
  const auto in_block = [](int c, int r) { return c >= 60 && c < 80 && r >= 90 && r < 110; };
  // Whole metres, which every type below holds exactly.
  const auto whole_hill = [](int c, int r) { return std::round(hill(c, r)); };
  writeHills(dir / "nan.tif", [&](int c, int r) { return in_block(c, r) ? NAN : whole_hill(c, r); });
  const std::tuple<std::string, GDALDataType, double> cases[] = {
      {"float64", GDT_Float64, 0.1},
      {"int32", GDT_Int32, 2147483647.0},
      {"float64_beyond_floats", GDT_Float64, -1e300}};
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  for (const auto& [name, type, nodata] : cases) {
    const fs::path dem = dir / (name + ".tif");
    writeDem(dem, kHillPixels, kHillPixels, gt, whole_hill, 4326, 1, type);
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(dem.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_NE(ds, nullptr);
    GDALRasterBand* band = ds->GetRasterBand(1);
    std::vector<double> block(20 * 20, nodata);
    ASSERT_EQ(band->RasterIO(GF_Write, 60, 90, 20, 20, block.data(), 20, 20, GDT_Float64, 0, 0), CE_None);
    ASSERT_EQ(band->SetNoDataValue(nodata), CE_None);
  }
  for (const std::string name : {"nan", "float64", "int32", "float64_beyond_floats"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name));
    ASSERT_EQ(r.exit_code, kExitOk) << name << "\n" << describe(r);
    EXPECT_FALSE(contains(r.err, "warning")) << describe(r);
    if (name != "nan") expectSameTiles(dir / "out" / "nan", dir / "out" / name);
  }
}

// GDAL 3.6 stores Int8 as Byte marked PIXELTYPE=SIGNEDBYTE and reads it as
// 0..255: such samples are read as the -128..127 they hold, a nodata value
// of -128 included, at every zoom (no overviews GDAL averaged as unsigned).
TEST(Inputs, SignedBytesAreReadAsTheSignedHeightsTheyHold) {
  const fs::path dir = caseDir();
  const auto height = [](int c, int r) {
    return c >= 60 && c < 80 && r >= 90 && r < 110 ? -128.0f
                                                   : float(std::round(100 * std::sin(c / 13.0) * std::cos(r / 17.0)));
  };
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "float.tif", kHillPixels, kHillPixels, gt,
           [&](int c, int r) { return height(c, r) == -128.0f ? NAN : height(c, r); });
  {
    const char* const options[] = {"PIXELTYPE=SIGNEDBYTE", nullptr};
    std::unique_ptr<GDALDataset> ds(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        (dir / "signed.tif").c_str(), kHillPixels, kHillPixels, 1, GDT_Byte, const_cast<char**>(options)));
    ASSERT_NE(ds, nullptr);
    double transform[6];
    std::copy(gt, gt + 6, transform);
    ds->SetGeoTransform(transform);
    OGRSpatialReference srs;
    srs.importFromEPSG(4326);
    ds->SetSpatialRef(&srs);
    std::vector<std::int8_t> bytes(std::size_t(kHillPixels) * kHillPixels);
    for (int r = 0; r < kHillPixels; ++r) {
      for (int c = 0; c < kHillPixels; ++c) {
        bytes[std::size_t(r) * kHillPixels + std::size_t(c)] = std::int8_t(height(c, r));
      }
    }
    GDALRasterBand* band = ds->GetRasterBand(1);
    ASSERT_EQ(band->RasterIO(GF_Write, 0, 0, kHillPixels, kHillPixels, bytes.data(), kHillPixels, kHillPixels, GDT_Byte,
                             0, 0),
              CE_None);
    ASSERT_EQ(band->SetNoDataValue(-128), CE_None);
  }
  for (const std::string name : {"float", "signed"}) {
    const RunResult r = run(tileArgs(dir / (name + ".tif"), dir / "out", name, "9-12"));
    ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
    EXPECT_FALSE(contains(r.err, "warning")) << describe(r);
  }
  expectSameTiles(dir / "out" / "float", dir / "out" / "signed");
  const RunResult info = run({"info", (dir / "signed.tif").string()});
  EXPECT_TRUE(contains(info.out, "Int8 (signed bytes)")) << describe(info);
}

// Heights stored in centimetres are all beyond the plausible range: the
// warning says so, and names the key that reads them, at coarse zooms (read
// from the reduced levels) as at the deepest.
TEST(Inputs, HeightsInCentimetresAreNamedWithTheKeyThatReadsThem) {
  const fs::path dir = caseDir();
  // Big enough for the reduced levels of the coarse zooms.
  constexpr int kSide = 512;
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "cm.tif", kSide, kSide, gt, [](int c, int r) { return std::round(hill(c, r) * 100); }, 4326, 1,
           GDT_Int32);
  writeDem(dir / "metres.tif", kSide, kSide, gt, [](int c, int r) { return std::round(hill(c, r) * 100) / 100; });
  for (const std::string zoom : {"6", "10"}) {
    const RunResult r = run(tileArgs(dir / "cm.tif", dir / "out", "cm" + zoom, zoom));
    EXPECT_EQ(r.exit_code, kExitNothingMade) << describe(r);
    EXPECT_TRUE(contains(r.err, "warning: dem: '" + (dir / "cm.tif").string() + "' holds heights")) << describe(r);
    EXPECT_TRUE(contains(r.err, "set heights.z_scale, 0.01 for centimetres")) << describe(r);
  }
  std::vector<std::string> scaled = tileArgs(dir / "cm.tif", dir / "out", "scaled", "6-10");
  scaled.insert(scaled.end(), {"--z-scale", "0.01"});
  const RunResult r = run(scaled);
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_FALSE(contains(r.err, "warning")) << describe(r);
  ASSERT_EQ(run(tileArgs(dir / "metres.tif", dir / "out", "metres", "6-10")).exit_code, kExitOk);
  const auto names = [](const std::map<std::string, std::string>& tiles) {
    std::vector<std::string> keys;
    for (const auto& entry : tiles) keys.push_back(entry.first);
    return keys;
  };
  EXPECT_EQ(names(tilesOf(dir / "out" / "scaled")), names(tilesOf(dir / "out" / "metres")));
}

TEST(Inputs, ImageBandsAreWarnedAboutAndComplexBandsRefused) {
  const fs::path dir = caseDir();
  const double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "rgb.tif", 64, 64, gt, [](int c, int r) { return float((c + r) % 256); }, 4326, 3, GDT_Byte);
  const RunResult rgb = run(tileArgs(dir / "rgb.tif", dir / "out", "rgb"));
  EXPECT_EQ(rgb.exit_code, kExitOk) << describe(rgb);
  EXPECT_TRUE(contains(rgb.err, "has 3 bands")) << describe(rgb);
  std::vector<std::string> band2 = tileArgs(dir / "rgb.tif", dir / "out", "rgb2");
  band2.insert(band2.end(), {"--band", "4"});
  const RunResult missing_band = run(band2);
  EXPECT_EQ(missing_band.exit_code, kExitInput) << describe(missing_band);
  EXPECT_TRUE(contains(missing_band.err, "asks for band 4")) << describe(missing_band);

  writeDem(dir / "complex.tif", 16, 16, gt, [](int, int) { return 1.0f; }, 4326, 1, GDT_CFloat32);
  const RunResult complex = run(tileArgs(dir / "complex.tif", dir / "out", "complex"));
  EXPECT_EQ(complex.exit_code, kExitInput) << describe(complex);
  EXPECT_TRUE(contains(complex.err, "complex")) << describe(complex);
}

TEST(Inputs, DemsPlacedOffTheEarthAreRefusedSayingWhere) {
  const fs::path dir = caseDir();
  const double gt[6] = {10, 0.1, 0, 95, 0, -0.1};
  writeDem(dir / "beyond.tif", 50, 50, gt, hill);
  const RunResult r = run(tileArgs(dir / "beyond.tif", dir / "out", "beyond"));
  EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
  EXPECT_TRUE(contains(r.err, "beyond -90..90")) << describe(r);

  // Metres a million kilometres out in a UTM zone: PROJ gives no reason, so the message shows the extent.
  const double far_gt[6] = {1e9, 30, 0, 1e9, 0, -30};
  writeDem(dir / "far.tif", 50, 50, far_gt, hill, 32632);
  for (const std::vector<std::string>& args :
       {tileArgs(dir / "far.tif", dir / "out", "far"), std::vector<std::string>{"info", (dir / "far.tif").string()}}) {
    const RunResult far = run(args);
    EXPECT_EQ(far.exit_code, kExitInput) << describe(far);
    EXPECT_TRUE(contains(far.err, "far.tif' (x 1000000000 to 1000001500, y 999998500 to 1000000000 in its CRS)"))
        << describe(far);
    EXPECT_TRUE(contains(far.err, "check its geotransform and CRS")) << describe(far);
  }

  // Pixels of 1,000 km in a UTM zone: its middle lies beyond the
  // projection's domain, which no scheme mends.
  const double huge_gt[6] = {499040, 1e6, 0, 100960, 0, -1e6};
  writeDem(dir / "huge.tif", 50, 50, huge_gt, hill, 32631);
  for (const std::vector<std::string>& args : {tileArgs(dir / "huge.tif", dir / "out", "huge", "0-auto"),
                                               std::vector<std::string>{"info", (dir / "huge.tif").string()}}) {
    const RunResult huge = run(args);
    EXPECT_EQ(huge.exit_code, kExitInput) << describe(huge);
    EXPECT_TRUE(contains(huge.err, "lies outside the CRS's domain (check the DEM's geotransform and CRS)"))
        << describe(huge);
  }
}

// A 50 x 50 hill placed by `gt` in the CRS `crs` names (as
// OGRSpatialReference::SetFromUserInput reads it).
fs::path writeDemInCrs(const fs::path& path, const double (&gt)[6], const char* crs) {
  writeDem(path, 50, 50, gt, hill);
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
  OGRSpatialReference srs;
  EXPECT_EQ(srs.SetFromUserInput(crs), OGRERR_NONE) << crs;
  EXPECT_TRUE(ds && ds->SetSpatialRef(&srs) == CE_None) << path;
  return path;
}

// `tile` and `info` of `dem` alone.
std::vector<RunResult> tileAndInfo(const fs::path& dem) {
  return {run(tileArgs(dem, dem.parent_path() / "out", "layer")), run({"info", dem.string()})};
}

// Its origin NaN: shown, rather than said to have no pixel size.
TEST(Inputs, AGeoTransformThatIsNoNumberIsRefusedShowingIt) {
  const fs::path dir = caseDir();
  const double no_origin[6] = {NAN, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "nan.tif", 50, 50, no_origin, hill);
  for (const RunResult& r : tileAndInfo(dir / "nan.tif")) {
    EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
    EXPECT_TRUE(contains(r.err,
                         "nan.tif' has a geotransform of origin (nan, 46) and pixels 0.001 by -0.001: each "
                         "must be a number, the pixel sizes not 0"))
        << describe(r);
  }
}

// A geocentric CRS (EPSG:4978) puts a grid on no surface: refused, for tile
// and info alike, rather than read as degrees at the pole.
TEST(Inputs, ADemInAGeocentricCrsIsRefused) {
  const double gt[6] = {4000000, 100, 0, 700000, 0, -100};
  for (const RunResult& r : tileAndInfo(writeDemInCrs(caseDir() / "ecef.tif", gt, "EPSG:4978"))) {
    EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
    EXPECT_TRUE(contains(r.err, "ecef.tif' is in a geocentric CRS")) << describe(r);
  }
}

// A GeoTIFF cut short loses its CRS tags first: the message says the file
// may be damaged, in GDAL's words, rather than ask for a CRS to be assigned.
TEST(Inputs, AGeoTiffCutShortIsNotTakenForOneWithoutACrs) {
  const fs::path dir = caseDir();
  const double gt[6] = {500000, 30, 0, 6650000, 0, -30};
  writeDem(dir / "cut.tif", 50, 50, gt, hill, 32633);
  fs::resize_file(dir / "cut.tif", 300);  // within the GeoTIFF keys' text
  const RunResult r = run({"info", (dir / "cut.tif").string()});
  EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
  EXPECT_TRUE(contains(r.err, "cut.tif' has no CRS GDAL can read; is the file whole? (GDAL: ")) << describe(r);
}

// A file whose header opens but whose pixels cannot be read (a GeoTIFF cut
// short in its pixels, a VRT whose source file is gone): every tile over it
// would fail, so the run stops at the first with one line naming the file,
// exit 3, and leaves no layer behind.
TEST(Inputs, ADemWhosePixelsCannotBeReadStopsTheRunNamingIt) {
  const fs::path dir = caseDir();
  writeHills(dir / "cut.tif");
  fs::resize_file(dir / "cut.tif", fs::file_size(dir / "cut.tif") / 2);
  writeHills(dir / "gone.tif");
  std::unique_ptr<GDALDataset> vrt(GetGDALDriverManager()->GetDriverByName("VRT")->CreateCopy(
      (dir / "mosaic.vrt").c_str(), GDALDataset::Open((dir / "gone.tif").c_str()), false, nullptr, nullptr, nullptr));
  ASSERT_NE(vrt, nullptr);
  vrt.reset();
  fs::remove(dir / "gone.tif");
  for (const std::string name : {"cut.tif", "mosaic.vrt"}) {
    const RunResult r = run(tileArgs(dir / name, dir / "out", name, "11-12"));
    EXPECT_EQ(r.exit_code, kExitInput) << name << ": " << describe(r);
    EXPECT_TRUE(contains(r.err, ": dem: cannot read a window of '" + (dir / name).string() + "' (")) << describe(r);
    EXPECT_TRUE(contains(r.err,
                         "; the run stopped there; the 0 tiles written are whole: repair or replace the file "
                         "and run it again with --resume"))
        << describe(r);
    EXPECT_EQ(r.err.find("error:"), r.err.rfind("error:")) << "one error line: " << describe(r);
    EXPECT_FALSE(fs::exists(dir / "out" / name)) << describe(r);
  }
}

// A Mars DEM: PROJ finds no way to the Earth's CRSs, and the frames would be
// the Earth's anyway; refused by the body's name, not with PROJ's WKT.
TEST(Inputs, ADemOfAnotherBodyIsRefusedNamingIt) {
  const double gt[6] = {10, 0.01, 0, 20, 0, -0.01};
  for (const RunResult& r : tileAndInfo(writeDemInCrs(caseDir() / "mars.tif", gt, "IAU_2015:49900"))) {
    EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
    EXPECT_TRUE(contains(r.err, "is in a CRS of another body than the Earth (Mars (2015) - Sphere, semi-major axis "
                                "3396190 m)"))
        << describe(r);
    EXPECT_FALSE(contains(r.err, "GEOGCRS")) << describe(r);
  }
}

// Eight pixels of 1e-12 degrees: at zooms 0-3 a texel spans some 1e11 of
// them, which the footprint mean once sized its weights by (std::bad_alloc
// for every tile, or the whole memory). Pixels past the raster weigh
// nothing: the job ends at once, as one that makes nothing.
TEST(Inputs, ATinyDemAtCoarseZoomsMakesNothingWithoutRunningOutOfMemory) {
  const fs::path dir = caseDir();
  const double gt[6] = {10, 1e-12, 0, 46, 0, -1e-12};
  writeDem(dir / "tiny.tif", 8, 8, gt, hill);
  test::ChildLimits limits;
  limits.address_space = std::size_t(3) << 30;
  const RunResult r = run(tileArgs(dir / "tiny.tif", dir / "out", "tiny", "0-3"), limits, std::chrono::seconds(60));
  EXPECT_EQ(r.exit_code, kExitNothingMade) << describe(r);
  EXPECT_TRUE(contains(r.err, "holds a valid DEM sample (the DEM is under two texels of zoom 3 wide and tall")) << describe(r);
  EXPECT_FALSE(contains(r.err, "bad_alloc")) << describe(r);
}

// A drone survey's DEM: 128 x 128 pixels of a centimetre in UTM, tiled
// from zoom 0 to its deepest in every scheme. Its backdrop's cells are 1 cm,
// 4 x 10^9 of them round the globe, which once overflowed a count of them
// (std::bad_alloc, "out of memory", for the first tile with holes).
TEST(Inputs, ADroneDemOfACentimetreTilesInEveryScheme) {
  const fs::path dir = caseDir();
  const double gt[6] = {500000, 0.01, 0, 5100000, 0, -0.01};
  const auto ripples = [](int c, int r) { return float(300 + 0.1 * std::sin(c / 9.0) + 0.001 * r); };
  writeDem(dir / "drone.tif", 128, 128, gt, ripples, 32632);
  for (const std::string scheme : {"webmercator", "geodetic", "native"}) {
    std::vector<std::string> args = tileArgs(dir / "drone.tif", dir / "out", scheme, "auto");
    args.insert(args.end(), {"--scheme", scheme});
    const RunResult r = run(args, {}, std::chrono::seconds(60));
    EXPECT_EQ(r.exit_code, kExitOk) << scheme << ": " << describe(r);
    EXPECT_TRUE(contains(r.out + r.err, " 0 failed)")) << scheme << ": " << describe(r);
    EXPECT_GE(tilesOf(dir / "out" / scheme).size(), 2u) << scheme << ": " << describe(r);
  }
}

// A whole world in Mollweide, voids beyond its ellipse: the corners of its
// extent lie outside the projection's domain, which once made its bounds
// untransformable ("cannot transform the extent", exit 3) in every scheme.
// In webmercator and geodetic it makes every tile of the world.
TEST(Inputs, AWorldInMollweideTilesTheWholeGlobe) {
  const fs::path dir = caseDir();
  constexpr double kHalfWidthM = 18040095.7, kHalfHeightM = 9020047.85;  // the ellipse's semi-axes, WGS84
  constexpr int kWidth = 200, kHeight = 100;
  const double gt[6] = {-kHalfWidthM, 2 * kHalfWidthM / kWidth, 0, kHalfHeightM, 0, -2 * kHalfHeightM / kHeight};
  const auto inside_ellipse = [&](int c, int r) {
    const double x = (c + 0.5) / kWidth * 2 - 1, y = (r + 0.5) / kHeight * 2 - 1;
    return x * x + y * y <= 1 ? float(1000 + 800 * std::sin(6 * x) * std::cos(3 * y)) : NAN;
  };
  const fs::path dem = dir / "mollweide.tif";
  writeDem(dem, kWidth, kHeight, gt, inside_ellipse);
  {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(dem.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    OGRSpatialReference mollweide;
    ASSERT_EQ(mollweide.SetFromUserInput("+proj=moll +datum=WGS84 +units=m +no_defs"), OGRERR_NONE);
    ASSERT_TRUE(ds && ds->SetSpatialRef(&mollweide) == CE_None);
  }
  const RunResult info = run({"info", dem.string()});
  EXPECT_TRUE(contains(info.out, "west -180.000000, south -90.000000, east 180.000000, north 90.000000"))
      << describe(info);
  for (const auto& [scheme, world_tiles] : {std::pair<std::string, std::size_t>{"webmercator", 4}, {"geodetic", 8}}) {
    std::vector<std::string> args = tileArgs(dem, dir / "out", scheme, "1");
    args.insert(args.end(), {"--scheme", scheme});
    const RunResult r = run(args);
    EXPECT_EQ(r.exit_code, kExitOk) << scheme << ": " << describe(r);
    EXPECT_TRUE(contains(r.out + r.err, " 0 empty, 0 failed)")) << scheme << ": " << describe(r);
    EXPECT_EQ(tilesOf(dir / "out" / scheme).size(), 2 * world_tiles) << scheme << ": " << describe(r);
  }
  // Native tiles reach past the ellipse, where points have no longitude and
  // latitude: each fails saying so (README, limitations).
  std::vector<std::string> args = tileArgs(dem, dir / "out", "native", "auto");
  args.insert(args.end(), {"--scheme", "native"});
  const RunResult native = run(args);
  EXPECT_EQ(native.exit_code, kExitTilesFailed) << describe(native);
  EXPECT_TRUE(contains(native.err, "part of the tile lies outside the CRS's domain; tile such a DEM in the "
                                   "webmercator or geodetic scheme"))
      << describe(native);
}

// A geostationary satellite's full disk: only the middles of its extent's
// edges touch the globe, and its bounds were once theirs alone, latitude 0
// to 0 ("nothing to make", exit 5). They are the disk's, 81.3 degrees each
// way from the satellite's nadir.
TEST(Inputs, AGeostationaryFullDiskIsBoundedByTheDisk) {
  const fs::path dir = caseDir();
  constexpr double kHalfWidthM = 5434177.8;  // the disk's edge, seen from 35,786 km
  const double gt[6] = {-kHalfWidthM, 2 * kHalfWidthM / 60, 0, kHalfWidthM, 0, -2 * kHalfWidthM / 60};
  const fs::path dem = dir / "disk.tif";
  writeDem(dem, 60, 60, gt, hill);
  {
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(dem.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    OGRSpatialReference geostationary;
    ASSERT_EQ(geostationary.SetFromUserInput("+proj=geos +h=35785831 +lon_0=0 +sweep=y +datum=WGS84 +no_defs"),
              OGRERR_NONE);
    ASSERT_TRUE(ds && ds->SetSpatialRef(&geostationary) == CE_None);
  }
  const RunResult info = run({"info", dem.string()});
  EXPECT_TRUE(contains(info.out, "west -81.299477, south -81.328194, east 81.299477, north 81.328194"))
      << describe(info);
  const RunResult r = run(tileArgs(dem, dir / "out", "disk", "2"));
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out + r.err, "wrote 8 tiles")) << describe(r);  // the middle two columns of zoom 2
}

// A UTM DEM tiled in the geodetic scheme from zoom 0: the middle tile of the
// coarse zooms reaches 80 degrees of longitude past the UTM zone, where the
// projection has no inverse. The read plan is then judged inside the DEM;
// it once stopped the job ("cannot transform a tile centre").
TEST(Inputs, UtmDemTilesInTheGeodeticSchemeFromZoomZero) {
  const fs::path dir = caseDir();
  const double gt[6] = {500000, 30, 0, 5100000, 0, -30};
  writeDem(dir / "utm.tif", 64, 64, gt, hill, 32632);
  std::vector<std::string> args = tileArgs(dir / "utm.tif", dir / "out", "utm", "0-12");
  args.insert(args.end(), {"--scheme", "geodetic"});
  const RunResult r = run(args);
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(fs::exists(dir / "out" / "utm" / "12")) << describe(r);
}

// Polar DEMs in the geodetic scheme, whose tiles reach a pole and their
// aprons past it: 20 km around the south pole in Antarctic polar
// stereographic (a texel there once made a footprint 1e19 pixels wide, and
// the read walked it for ever), and 20 km across the antimeridian near the
// north pole in NSIDC's (its longitudes come back west > east, which once
// sized the backdrop negative: "unexpected: cannot create std::vector");
// and 200 km around the south pole, whose backdrop's cells are so large that
// one cell south of its centre lies past the pole (which once failed every
// tile: "cannot transform a tile centre").
TEST(Inputs, PolarDemsTileInTheGeodeticScheme) {
  const fs::path dir = caseDir();
  const double gt[6] = {-100000, 100, 0, 100000, 0, -100};
  writeDem(dir / "antarctic.tif", kHillPixels, kHillPixels, gt, hill, 3031);
  writeDem(dir / "arctic.tif", kHillPixels, kHillPixels, gt, hill, 3413);
  const double wide[6] = {-100000, 1000, 0, 100000, 0, -1000};
  writeDem(dir / "antarctic_wide.tif", kHillPixels, kHillPixels, wide, hill, 3031);
  for (const std::string name : {"antarctic", "arctic", "antarctic_wide"}) {
    std::vector<std::string> args = tileArgs(dir / (name + ".tif"), dir / "out", name, "auto");
    args.insert(args.end(), {"--scheme", "geodetic"});
    const RunResult r = run(args, {}, std::chrono::seconds(60));
    EXPECT_EQ(r.exit_code, kExitOk) << name << ": " << describe(r);
    EXPECT_TRUE(contains(r.out + r.err, " 0 failed)")) << name << ": " << describe(r);
    const RunResult info = run({"info", (dir / (name + ".tif")).string()});
    EXPECT_TRUE(contains(info.out, "webmercator  none: the DEM lies beyond the latitudes its tiles reach"))
        << name << ": " << describe(info);
  }
}

// A polar stereographic DEM 30 km across, on the south pole, at a zoom whose
// texels are coarser than its pixels: the geodetic texels on the pole have
// no neighbour south of them, and once never held data, so this DEM, all of
// it within one texel row of the pole, made nothing (exit 5, 32 tiles empty).
TEST(Inputs, TexelsOnAPoleHoldTheDataAroundIt) {
  const fs::path dir = caseDir();
  const double gt[6] = {-15000, 1000, 0, 15000, 0, -1000};
  writeDem(dir / "pole.tif", 30, 30, gt, hill, 3031);
  std::vector<std::string> args = tileArgs(dir / "pole.tif", dir / "out", "pole", "4");
  args.insert(args.end(), {"--scheme", "geodetic", "--tile-size", "64", "--alpha", "true"});
  const RunResult r = run(args);
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out + r.err, "wrote 32 tiles")) << describe(r);  // every longitude of the pole's row
}

// A lon/lat DEM from 80 degrees north to the pole, in Web Mercator, whose map
// stops at 85.05: auto's zoom is judged at the middle of the part on the
// map, and a box of the part beyond it is refused saying so. Its 0.05-degree pixels are 1,650 m on the ground at the DEM's centre;
// at 82.9 degrees, halfway up that part in Mercator, zoom 3's texels are
// 2,420 m and zoom 4's 1,210 m, so auto is 3. (Judged over the DEM's whole
// extent, which runs to infinity in Mercator, it once came out as 0.)
TEST(Inputs, ADemReachingThePoleGetsTheAutoZoomOfItsPartOnTheMap) {
  const fs::path dir = caseDir();
  const double gt[6] = {10, 0.05, 0, 90, 0, -0.05};
  writeDem(dir / "arctic.tif", kHillPixels, kHillPixels, gt, hill);
  const RunResult info = run({"info", (dir / "arctic.tif").string()});
  EXPECT_TRUE(contains(info.out, "webmercator  3-3, 1 tiles")) << describe(info);
  const RunResult r = run(tileArgs(dir / "arctic.tif", dir / "out", "arctic", "auto"));
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(fs::exists(dir / "out" / "arctic" / "3" / "4" / "0.png")) << describe(r);
  EXPECT_FALSE(fs::exists(dir / "out" / "arctic" / "4")) << describe(r);
  // A box of the DEM beyond that map is named as such.
  std::vector<std::string> args = tileArgs(dir / "arctic.tif", dir / "out", "box", "3");
  args.insert(args.end(), {"--bbox", "10,86,20,89"});
  const RunResult box = run(args);
  EXPECT_EQ(box.exit_code, kExitNothingMade) << describe(box);
  EXPECT_TRUE(contains(box.err, "does not overlap the part of '" + (dir / "arctic.tif").string() +
                                    "' that webmercator tiles reach (lon 10 to 20, lat 80 to 85.051129; use "
                                    "--scheme geodetic or native for the rest)"))
      << describe(box);
}

// Tiles of one raster given as a list (SRTM's 1-degree files, sharing their
// edge rows and columns as those do) make the bytes of the one file they
// were cut from: a kernel near a seam reads the next file's samples, not an
// extrapolation past each file's edge (which once put seams up to 13 steps
// deep along the files' edges).
TEST(Inputs, TilesOfOneRasterGivenAsAListMakeTheTilesOfTheWholeFile) {
  const fs::path dir = caseDir();
  constexpr int kSide = 401, kHalf = 200;
  constexpr double kNoData = -32768;
  // Int16 declaring a nodata value, as SRTM; Float32 declaring none.
  for (const GDALDataType type : {GDT_Int16, GDT_Float32}) {
    const std::string kind = GDALGetDataTypeName(type);
    SCOPED_TRACE(kind);
    const auto declareNoData = [&](const fs::path& path) {
      if (type != GDT_Int16) return;
      std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
      ASSERT_NE(ds, nullptr);
      ASSERT_EQ(ds->GetRasterBand(1)->SetNoDataValue(kNoData), CE_None);
    };
    const double whole_gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
    writeDem(dir / (kind + "_whole.tif"), kSide, kSide, whole_gt, hill, 4326, 1, type);
    declareNoData(dir / (kind + "_whole.tif"));
    ASSERT_EQ(run(tileArgs(dir / (kind + "_whole.tif"), dir / "out", kind + "_whole")).exit_code, kExitOk);
    std::vector<std::string> args = tileArgs(dir / "unused.tif", dir / "out", kind + "_pieces");
    args.erase(args.begin() + 1, args.begin() + 3);  // "--dem", the path
    for (int row = 0; row < 2; ++row) {
      for (int col = 0; col < 2; ++col) {
        const fs::path piece = dir / (kind + "_piece" + std::to_string(row) + std::to_string(col) + ".tif");
        const double gt[6] = {kHillWest + col * kHalf * kHillPixelDeg, kHillPixelDeg, 0,
                              kHillNorth - row * kHalf * kHillPixelDeg, 0, -kHillPixelDeg};
        writeDem(piece, kHalf + 1, kHalf + 1, gt,
                 [&](int c, int r) { return hill(c + col * kHalf, r + row * kHalf); }, 4326, 1, type);
        declareNoData(piece);
        args.insert(args.end(), {"--dem", piece.string()});
      }
    }
    const RunResult r = run(args);
    ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
    expectSameTiles(dir / "out" / (kind + "_whole"), dir / "out" / (kind + "_pieces"));
  }
}

// Longitudes counted 0 to 360: the same hills at 190 E and at 170 W make the
// same tiles, and the job plans no tile beyond them (it once planned 456
// empty ones at zoom 12, from a piece of the box running west > east, and
// in the geodetic scheme found no DEM sample at all).
TEST(Inputs, LongitudesCountedTo360TileLikeTheSamePlaceCountedFromMinus180) {
  const fs::path dir = caseDir();
  const double past_180[6] = {190, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  const double before_180[6] = {-170, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "past.tif", kHillPixels, kHillPixels, past_180, hill);
  writeDem(dir / "before.tif", kHillPixels, kHillPixels, before_180, hill);
  for (const std::string scheme : {"webmercator", "geodetic"}) {
    const auto runOf = [&](const std::string& name) {
      std::vector<std::string> args = tileArgs(dir / (name + ".tif"), dir / scheme, name);
      args.insert(args.end(), {"--scheme", scheme});
      return run(args);
    };
    const RunResult past = runOf("past"), before = runOf("before");
    ASSERT_EQ(past.exit_code, kExitOk) << scheme << ": " << describe(past);
    ASSERT_EQ(before.exit_code, kExitOk) << scheme << ": " << describe(before);
    EXPECT_TRUE(contains(past.out + past.err, "(0 skipped, 0 empty, 0 failed)")) << scheme << ": " << describe(past);
    expectSameTiles(dir / scheme / "past", dir / scheme / "before");
  }
}

// Web Mercator DEMs stored past the map's edge, x = ±20,037,508 m (as
// gdalwarp writes a DEM across the antimeridian): one wholly past it tiles
// like the same place counted a turn west, and one across it like its twin
// across the west edge, every tile with data, in both schemes. Their tiles
// east of 180 degrees were once all empty, the reads never a turn round.
TEST(Inputs, WebMercatorDemsPastTheMapsEdgeTileLikeTheSamePlaceATurnRound) {
  const fs::path dir = caseDir();
  constexpr double kHalfTurnM = 20037508.342789244, kPixelM = 1000, kNorthM = -1800000;
  const std::vector<std::pair<std::string, double>> wests = {{"past", kHalfTurnM + 60000},
                                                             {"turned_past", -kHalfTurnM + 60000},
                                                             {"across", kHalfTurnM - 100000},
                                                             {"turned_across", -kHalfTurnM - 100000}};
  for (const auto& [name, west] : wests) {
    const double gt[6] = {west, kPixelM, 0, kNorthM, 0, -kPixelM};
    writeDem(dir / (name + ".tif"), kHillPixels, kHillPixels, gt, hill, 3857);
  }
  for (const std::string scheme : {"webmercator", "geodetic"}) {
    for (const auto& [name, west] : wests) {
      std::vector<std::string> args = tileArgs(dir / (name + ".tif"), dir / scheme, name, "5-8");
      args.insert(args.end(), {"--scheme", scheme});
      const RunResult r = run(args);
      ASSERT_EQ(r.exit_code, kExitOk) << scheme << " " << name << ": " << describe(r);
      EXPECT_TRUE(contains(r.out + r.err, "(0 skipped, 0 empty, 0 failed)"))
          << scheme << " " << name << ": " << describe(r);
    }
    expectSameTiles(dir / scheme / "past", dir / scheme / "turned_past");
    expectSameTiles(dir / scheme / "across", dir / scheme / "turned_across");
  }
}

// 0.2 degrees across the antimeridian at 50 N, stored from 179.9 to 180.1:
// zoom 12 has 4 tiles a side there (1 or 2 columns each side), not 4096.
TEST(Inputs, DemAcrossTheAntimeridianPlansOnlyItsTiles) {
  const fs::path dir = caseDir();
  const double gt[6] = {179.9, kHillPixelDeg, 0, 50, 0, -kHillPixelDeg};
  writeDem(dir / "across.tif", kHillPixels, kHillPixels, gt, hill);
  // Web Mercator, and the geodetic scheme, whose lon/lat grid once met the
  // DEM's pixels past 180 nowhere: its tiles west of 180 came out empty.
  for (const std::string scheme : {"webmercator", "geodetic"}) {
    std::vector<std::string> args = tileArgs(dir / "across.tif", dir / scheme, "across");
    args.insert(args.end(), {"--scheme", scheme});
    const RunResult r = run(args);
    ASSERT_EQ(r.exit_code, kExitOk) << scheme << ": " << describe(r);
    // 0.088 degrees a Web Mercator tile, 0.044 a geodetic one
    const std::string planned = scheme == "webmercator" ? "zoom 12: 16 tiles" : "zoom 12: 30 tiles";
    EXPECT_TRUE(contains(r.err, planned)) << scheme << ": " << describe(r);
    EXPECT_TRUE(contains(r.out + r.err, "(0 skipped, 0 empty, 0 failed)")) << scheme << ": " << describe(r);
    const int last_column = scheme == "webmercator" ? 4095 : 8191;
    bool west = false, east = false;  // both sides of the antimeridian
    for (const auto& [name, bytes] : tilesOf(dir / scheme / "across")) {
      west = west || name.rfind("12/" + std::to_string(last_column) + "/", 0) == 0;
      east = east || name.rfind("12/0/", 0) == 0;
    }
    EXPECT_TRUE(west && east) << scheme << ": " << describe(r);
    // tilejson's bounds cross the antimeridian as TileJSON writes it: west
    // above east, and the centre half way along, wrapped.
    const auto tilejson = nlohmann::json::parse(test::readBytes(dir / scheme / "across" / "tilejson.json"));
    const double span = kHillPixels * kHillPixelDeg;
    EXPECT_NEAR(tilejson.at("bounds").at(0).get<double>(), 179.9, 1e-9) << scheme;
    EXPECT_NEAR(tilejson.at("bounds").at(1).get<double>(), 50 - span, 1e-9) << scheme;
    EXPECT_NEAR(tilejson.at("bounds").at(2).get<double>(), 179.9 + span - 360, 1e-9) << scheme;
    EXPECT_NEAR(tilejson.at("bounds").at(3).get<double>(), 50, 1e-9) << scheme;
    EXPECT_NEAR(tilejson.at("center").at(0).get<double>(), 179.9 + span / 2 - 360, 1e-9) << scheme;
  }
  // The native grid is the DEM's own, one area: its zoom 0 is one tile (the
  // plan once took the two pieces of the lon/lat cover, which native tiling
  // has no place for, and read an empty optional).
  std::vector<std::string> native_args = tileArgs(dir / "across.tif", dir / "native", "across", "0");
  native_args.insert(native_args.end(), {"--scheme", "native"});
  const RunResult native = run(native_args);
  EXPECT_EQ(native.exit_code, kExitOk) << describe(native);
  EXPECT_TRUE(contains(native.out, "wrote 1 tiles")) << describe(native);
  // `info` counts the tiles of both pieces, as the job plans them (it once
  // counted whole rows of the world: 3,071 tiles down to zoom 10).
  const RunResult info = run({"info", (dir / "across.tif").string()});
  EXPECT_EQ(info.exit_code, kExitOk) << describe(info);
  EXPECT_TRUE(contains(info.out, "webmercator  7-10, 14 tiles: z7 2, z8 4, z9 4, z10 4")) << describe(info);
}

// The names of a layer's tiles.
std::set<std::string> tileNamesOf(const fs::path& layer) {
  std::set<std::string> names;
  for (const auto& [name, bytes] : tilesOf(layer)) names.insert(name);
  return names;
}

// Files far apart, listed in one job, plan the tiles round each: the job
// makes the tiles each file's own job makes, and plans none between them
// (the box over both once planned 1.5 million tiles at zoom 12 to write 30).
// So does a VRT of them, round each of its sources.
TEST(Inputs, FilesFarApartPlanOnlyTheTilesRoundEach) {
  const fs::path dir = caseDir();
  writeHills(dir / "alps.tif");
  const double fiji[6] = {178.0, kHillPixelDeg, 0, -17.0, 0, -kHillPixelDeg};
  writeDem(dir / "fiji.tif", kHillPixels, kHillPixels, fiji, hill);
  std::set<std::string> apart;
  for (const std::string name : {"alps", "fiji"}) {
    const RunResult alone = run(tileArgs(dir / (name + ".tif"), dir / "out", name));
    ASSERT_EQ(alone.exit_code, kExitOk) << describe(alone);
    for (const std::string& tile : tileNamesOf(dir / "out" / name)) apart.insert(tile);
  }
  std::vector<std::string> args = tileArgs(dir / "alps.tif", dir / "out", "both");
  args.insert(args.end(), {"--dem", (dir / "fiji.tif").string()});
  const RunResult both = run(args);
  ASSERT_EQ(both.exit_code, kExitOk) << describe(both);
  EXPECT_TRUE(contains(both.err, "zoom 12: " + std::to_string(apart.size() / 2) + " tiles")) << describe(both);
  EXPECT_TRUE(contains(both.out, "(0 skipped, 0 empty, 0 failed)")) << describe(both);
  EXPECT_EQ(tileNamesOf(dir / "out" / "both"), apart);
  // `info` counts them so too: one tile at zoom 0, then each file's own (the
  // box over both has 94,842 tiles at zoom 10).
  const RunResult info = run({"info", (dir / "alps.tif").string(), (dir / "fiji.tif").string()});
  EXPECT_TRUE(contains(info.out, "webmercator  0-10, 24 tiles: z0 1, z1 2, z2 2,")) << describe(info);

  // A VRT of both is one file whose sources lie far apart: it plans the same
  // tiles, round each source, and `info` counts them so.
  const std::string names[] = {(dir / "alps.tif").string(), (dir / "fiji.tif").string()};
  const char* const sources[] = {names[0].c_str(), names[1].c_str()};
  GDALDatasetH vrt = GDALBuildVRT((dir / "both.vrt").c_str(), 2, nullptr, sources, nullptr, nullptr);
  ASSERT_NE(vrt, nullptr);
  GDALClose(vrt);
  const RunResult from_vrt = run(tileArgs(dir / "both.vrt", dir / "out", "vrt"));
  ASSERT_EQ(from_vrt.exit_code, kExitOk) << describe(from_vrt);
  EXPECT_TRUE(contains(from_vrt.err, "zoom 12: " + std::to_string(apart.size() / 2) + " tiles")) << describe(from_vrt);
  EXPECT_TRUE(contains(from_vrt.out, "(0 skipped, 0 empty, 0 failed)")) << describe(from_vrt);
  EXPECT_EQ(tileNamesOf(dir / "out" / "vrt"), apart);
  const RunResult vrt_info = run({"info", (dir / "both.vrt").string()});
  EXPECT_TRUE(contains(vrt_info.out, "webmercator  0-10, 24 tiles: z0 1, z1 2, z2 2,")) << describe(vrt_info);
  EXPECT_TRUE(contains(vrt_info.out, "sources    in 2 groups apart")) << describe(vrt_info);

  // A box between them holds no file: nothing to make, said at once.
  args.insert(args.end(), {"--bbox", "60,0,61,1"});
  const RunResult between = run(args);
  EXPECT_EQ(between.exit_code, kExitNothingMade) << describe(between);
  EXPECT_TRUE(contains(between.err, "tiling.bbox: lon 60 to 61, lat 0 to 1 lies between the files of")) << describe(between);
}

// gdalbuildvrt gives a VRT of sources without a nodata value none, and GDAL
// reads 0 where no source reaches: no height there, as in a VRT that says
// so (-vrtnodata nan), at the deepest zoom and the coarser ones.
TEST(Inputs, AVrtWithoutNodataHasNoHeightsWhereNoneOfItsSourcesReaches) {
  const fs::path dir = caseDir();
  constexpr int kGapFrom = 90, kGapTo = 110;  // the columns no source covers
  double gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "west.tif", kGapFrom, kHillPixels, gt, hill);
  gt[0] = kHillWest + kGapTo * kHillPixelDeg;
  writeDem(dir / "east.tif", kHillPixels - kGapTo, kHillPixels, gt, [](int c, int r) { return hill(c + kGapTo, r); });
  const std::string names[] = {(dir / "west.tif").string(), (dir / "east.tif").string()};
  const char* const sources[] = {names[0].c_str(), names[1].c_str()};
  const char* const say_nan[] = {"-vrtnodata", "nan", nullptr};
  GDALBuildVRTOptions* nan_options = GDALBuildVRTOptionsNew(const_cast<char**>(say_nan), nullptr);
  for (const auto& [name, options] :
       {std::pair<std::string, GDALBuildVRTOptions*>{"plain", nullptr}, {"nan", nan_options}}) {
    GDALDatasetH vrt = GDALBuildVRT((dir / (name + ".vrt")).c_str(), 2, nullptr, sources, options, nullptr);
    ASSERT_NE(vrt, nullptr);
    GDALClose(vrt);
    const RunResult r = run(tileArgs(dir / (name + ".vrt"), dir / "out", name, "9-12"));
    ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  }
  GDALBuildVRTOptionsFree(nan_options);
  expectSameTiles(dir / "out" / "nan", dir / "out" / "plain");
  const RunResult info = run({"info", (dir / "plain.vrt").string()});
  EXPECT_TRUE(contains(info.out, "mask       no data where none of its sources reaches")) << describe(info);
}

// `tile` of the files `names` (.tif in `dir`, in that order) into
// dir/out/`layer` at zooms `zoom`, expected to succeed.
RunResult tileFiles(const fs::path& dir, const std::string& layer, const std::vector<std::string>& names,
                    const std::string& zoom) {
  std::vector<std::string> args = tileArgs(dir / (names.front() + ".tif"), dir / "out", layer, zoom);
  for (std::size_t i = 1; i < names.size(); ++i) {
    args.insert(args.end(), {"--dem", (dir / (names[i] + ".tif")).string()});
  }
  const RunResult r = run(args);
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  return r;
}

// Expects every tile of the layer `own` in the layer `listed`, byte for byte.
void expectOwnTilesAmong(const fs::path& own, const fs::path& listed) {
  const auto own_tiles = tilesOf(own), listed_tiles = tilesOf(listed);
  ASSERT_FALSE(own_tiles.empty()) << own;
  for (const auto& [name, bytes] : own_tiles) {
    const auto it = listed_tiles.find(name);
    ASSERT_NE(it, listed_tiles.end()) << name;
    EXPECT_TRUE(it->second == bytes) << name << " differs from its own job's";
  }
}

// A file listed with others far away makes the bytes of its own job: its
// reads and auto's zoom are judged in the middle of its own area, its
// backdrop covers its own area, and files that are tiles of one raster are
// read as one mosaic within their group. Judged in the middle of the box
// over all, every Alpine tile of the sample listed with a DEM at Fiji
// differed from its own run's, by up to 27 levels.
TEST(Inputs, FilesFarApartMakeTheBytesOfTheirOwnJobs) {
  const fs::path dir = caseDir();
  // The Alpine hills in two halves, tiles of one raster; Fiji's pixels are
  // finer, so that auto chooses a deeper zoom there.
  const int half = kHillPixels / 2;
  const double west_gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  const double east_gt[6] = {kHillWest + half * kHillPixelDeg, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "west.tif", half, kHillPixels, west_gt, hill);
  writeDem(dir / "east.tif", half, kHillPixels, east_gt, [&](int c, int r) { return hill(c + half, r); });
  const double fiji_gt[6] = {178.0, kHillPixelDeg / 2, 0, -17.0, 0, -kHillPixelDeg / 2};
  writeDem(dir / "fiji.tif", 300, 300, fiji_gt, hill);
  const auto job = [&](const std::string& layer, const std::vector<std::string>& names) {
    return tileFiles(dir, layer, names, "10-auto");
  };
  const RunResult alps = job("alps", {"west", "east"});
  const RunResult fiji = job("fiji", {"fiji"});
  EXPECT_FALSE(contains(alps.err, "zoom 11:")) << describe(alps);
  EXPECT_TRUE(contains(fiji.err, "zoom 11:")) << describe(fiji);
  // max_error_texels is judged in the first file's group: each group listed first.
  const RunResult alps_first = job("alps_first", {"west", "east", "fiji"});
  const RunResult fiji_first = job("fiji_first", {"fiji", "west", "east"});
  expectOwnTilesAmong(dir / "out" / "alps", dir / "out" / "alps_first");
  expectOwnTilesAmong(dir / "out" / "fiji", dir / "out" / "fiji_first");
  // Auto's zoom suits every group: Fiji's, the deeper.
  EXPECT_TRUE(contains(alps_first.err, "zoom 11:")) << describe(alps_first);
  const RunResult info =
      run({"info", (dir / "west.tif").string(), (dir / "east.tif").string(), (dir / "fiji.tif").string()});
  EXPECT_TRUE(contains(info.out, "webmercator  0-11,")) << describe(info);
}

// At zooms whose texels span several of their pixels, files of two rasters
// listed together each read the reduced levels their own jobs read (they
// share the levels' memory by their pixels, and together hold far less
// than a file alone may): the bytes of their own jobs. (Only a DEM read as
// one raster once got levels, so such a file, listed with another, averaged
// its own pixels: the same heights to a few centimetres, other bytes.) A
// job whose tiles lie inside one file, with no hole to fill from the
// backdrop (which reads every file), makes no levels of the other.
TEST(Inputs, FilesOfTwoRastersListedTogetherReadTheReducedLevelsOfTheirOwnJobs) {
  const fs::path dir = caseDir();
  // 2 degrees of the Alps, so that whole tiles of zoom 9 lie inside it, and 0.5 of Fiji.
  const double alps_gt[6] = {kHillWest, kHillPixelDeg, 0, kHillNorth, 0, -kHillPixelDeg};
  writeDem(dir / "alps.tif", 2048, 2048, alps_gt, hill);
  const double fiji_gt[6] = {178.0, kHillPixelDeg / 2, 0, -17.0, 0, -kHillPixelDeg / 2};
  writeDem(dir / "fiji.tif", 1024, 1024, fiji_gt, hill);
  for (const std::string name : {"alps", "fiji"}) {
    SCOPED_TRACE(name);
    const RunResult alone = tileFiles(dir, name, {name}, "7-9");
    EXPECT_TRUE(contains(alone.err, "reduced levels of")) << describe(alone);
    // Each listed first: max_error_texels is judged in the first file's area.
    tileFiles(dir, name + "_listed", {name, name == "alps" ? "fiji" : "alps"}, "7-9");
    expectOwnTilesAmong(dir / "out" / name, dir / "out" / (name + "_listed"));
  }
  // A tile of zoom 9, with its apron, inside the Alps.
  std::vector<std::string> args = tileArgs(dir / "alps.tif", dir / "out", "alps_box", "9");
  args.insert(args.end(), {"--dem", (dir / "fiji.tif").string(), "--bbox", "10.6,45.1,11.2,45.5"});
  const RunResult box = run(args);
  EXPECT_EQ(box.exit_code, kExitOk) << describe(box);
  EXPECT_TRUE(contains(box.out + box.err, "wrote 1 tiles")) << describe(box);
  EXPECT_TRUE(contains(box.err, "reduced levels of '" + (dir / "alps.tif").string())) << describe(box);
  EXPECT_FALSE(contains(box.err, "reduced levels of '" + (dir / "fiji.tif").string())) << describe(box);
}

// Hundreds of files far apart (islands' tiles) each get a part of the
// backdrop, and a coarse tile among them takes each texel's from the part
// nearest to it by comparing only the parts near its block: comparing every
// part for every texel of every part once kept such a job busy for hours.
TEST(Inputs, HundredsOfFilesFarApartTileInSeconds) {
  const fs::path dir = caseDir();
  constexpr int kSide = 20;  // files a side, a degree apart
  for (int i = 0; i < kSide; ++i) {
    for (int j = 0; j < kSide; ++j) {
      const double gt[6] = {-100.0 + i, 0.01, 0, 40.0 - j, 0, -0.01};
      writeDem(dir / ("island_" + std::to_string(i) + "_" + std::to_string(j) + ".tif"), 20, 20, gt,
               [&](int c, int r) { return float(100 + 10 * i + j + c + r); });
    }
  }
  const RunResult r = run(tileArgs(dir / "island_*.tif", dir / "out", "islands", "3-6"), {},
                          std::chrono::seconds(int(120 * test::kSanitizerSlowdown)));
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, ", 0 failed)")) << describe(r);
  EXPECT_LT(r.seconds, 60 * test::kSanitizerSlowdown) << describe(r);
}

// World DEMs registered on pixel centres (ETOPO's and GMTED's grids) run
// half a pixel past -180 and 180: they are the whole globe, in every scheme,
// not a sliver east of the antimeridian (once one tile column in the
// geodetic scheme and the native one).
TEST(Inputs, AWorldDemOfPixelCentresTilesTheWholeGlobe) {
  const fs::path dir = caseDir();
  const auto world = [](int c, int r) { return float(2000 * std::sin(c * 0.05) * std::cos(r * 0.03)); };
  const double edges[6] = {-180, 1, 0, 90, 0, -1};
  writeDem(dir / "edges.tif", 360, 180, edges, world);
  const double centres[6] = {-180.5, 1, 0, 90.5, 0, -1};
  writeDem(dir / "centres.tif", 360, 181, centres, world);
  // Counted 0 to 360: Web Mercator tiles west of 0 once read nothing.
  const double from_zero[6] = {-0.5, 1, 0, 90.5, 0, -1};
  writeDem(dir / "from_zero.tif", 360, 181, from_zero, [&](int c, int r) { return world((c + 180) % 360, r); });
  for (const std::string name : {"edges", "centres", "from_zero"}) {
    SCOPED_TRACE(name);
    const RunResult info = run({"info", (dir / (name + ".tif")).string()});
    ASSERT_EQ(info.exit_code, kExitOk) << describe(info);
    EXPECT_TRUE(contains(info.out, "geodetic     0-0, 2 tiles: z0 2\n")) << describe(info);
    EXPECT_TRUE(contains(info.out, "native       0-1, 3 tiles: z0 1, z1 2\n")) << describe(info);
    // Zooms 0-2: 1 + 4 + 16 tiles in Web Mercator, 2 + 8 + 32 geodetic;
    // native has 0-1 (1 + 2).
    for (const auto& [scheme, tiles] : std::map<std::string, int>{{"webmercator", 21}, {"geodetic", 42}, {"native", 3}}) {
      std::vector<std::string> args =
          tileArgs(dir / (name + ".tif"), dir / scheme, name, scheme == "native" ? "0-1" : "0-2");
      args.insert(args.end(), {"--scheme", scheme});
      const RunResult r = run(args);
      ASSERT_EQ(r.exit_code, kExitOk) << scheme << ": " << describe(r);
      EXPECT_TRUE(contains(r.out + r.err, "wrote " + std::to_string(tiles) + " tiles")) << scheme << ": " << describe(r);
      EXPECT_TRUE(contains(r.out + r.err, "(0 skipped, 0 empty, 0 failed)")) << scheme << ": " << describe(r);
    }
  }
}

// Heights smooth round the globe, at a longitude counted from -180 and a
// colatitude: whole waves along each parallel, none at the poles.
float broadWorldHeight(double lon_from_west_deg, double colat_deg) {
  const double lon = lon_from_west_deg * M_PI / 180, colat = colat_deg * M_PI / 180;
  return float(1500 * std::sin(3 * lon + 1) * std::sin(colat) + 800 * std::cos(2 * colat + std::cos(lon)));
}

// Expects DEMs `a` and `b` (.tif files in `dir`) to make the same tiles at
// zooms 0-2 in the Web Mercator and geodetic schemes (see expectSameTiles).
void expectSameWorldTiles(const fs::path& dir, const std::string& a, const std::string& b, int png_steps = 0) {
  for (const std::string scheme : {"webmercator", "geodetic"}) {
    SCOPED_TRACE(scheme);
    for (const std::string& name : {a, b}) {
      std::vector<std::string> args = tileArgs(dir / (name + ".tif"), dir / scheme, name, "0-2");
      args.insert(args.end(), {"--scheme", scheme});
      const RunResult r = run(args);
      ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
    }
    expectSameTiles(dir / scheme / a, dir / scheme / b, png_steps);
  }
}

// A whole-globe DEM reads on across the antimeridian and across the poles
// as anywhere else, so where its columns start changes nothing: counted
// from -180 or from 0, it makes the same bytes. (Both once read a border of
// two pixels across the antimeridian and invented the rows past a pole: the
// geodetic tiles at the poles differed by up to 223 steps.)
TEST(Inputs, AWholeGlobeDemMakesTheSameTilesWhereverItsColumnsStart) {
  const fs::path dir = caseDir();
  const auto world = [](int c, int r) { return broadWorldHeight(c + 0.5, r + 0.5); };
  const double from_minus_180[6] = {-180, 1, 0, 90, 0, -1};
  writeDem(dir / "minus180.tif", 360, 180, from_minus_180, world);
  const double from_zero[6] = {0, 1, 0, 90, 0, -1};
  writeDem(dir / "zero.tif", 360, 180, from_zero, [&](int c, int r) { return world((c + 180) % 360, r); });
  expectSameWorldTiles(dir, "minus180", "zero");
}

// The same for a Web Mercator world, 40,075 km wide, to 85 degrees north
// and south: counted from the map's west edge or from 0 m (to 40,075 km,
// half of it past the map's east edge), it makes the same tiles. Its pixels
// of 111,319.49 m, counted a turn apart, round differently in the last
// bits, which may move a texel across a step. (Counted from 0 m, its
// longitudes once came out as 0 to 0: the job tiled half the world in Web
// Mercator and stopped on SIGFPE in the geodetic scheme; and the tiles
// either side of the antimeridian were read only to the DEM's edge there.)
TEST(Inputs, AWholeWebMercatorWorldMakesTheSameTilesWhereverItsColumnsStart) {
  constexpr int kRoundingSteps = 1;
  const fs::path dir = caseDir();
  constexpr double kHalfTurnM = 20037508.342789244, kPixelM = 2 * kHalfTurnM / 360;
  const auto world = [](int c, int r) { return broadWorldHeight(c + 0.5, 5 + r / 2.0); };
  const double from_west[6] = {-kHalfTurnM, kPixelM, 0, kHalfTurnM, 0, -kPixelM};
  writeDem(dir / "west.tif", 360, 360, from_west, world, 3857);
  const double from_zero[6] = {0, kPixelM, 0, kHalfTurnM, 0, -kPixelM};
  writeDem(
      dir / "zero.tif", 360, 360, from_zero, [&](int c, int r) { return world((c + 180) % 360, r); }, 3857);
  expectSameWorldTiles(dir, "west", "zero", kRoundingSteps);
}

// A world DEM of pixel centres from -180 to 180 (ETOPO1's grid-registered
// files, GMT's gridline grids) repeats a column at the antimeridian: it is
// the whole globe too, read across the antimeridian as one without the
// repeat. (It was once read only to its edges there: the tiles either side
// of the antimeridian differed from those of the same world 360 columns wide.)
TEST(Inputs, AWorldDemRepeatingItsFirstColumnAt180ReadsAcrossTheAntimeridian) {
  const fs::path dir = caseDir();
  const auto world = [](int c, int r) { return broadWorldHeight(c, r); };  // column 360 is column 0
  const double centres[6] = {-180.5, 1, 0, 90.5, 0, -1};
  writeDem(dir / "repeated.tif", 361, 181, centres, world);
  writeDem(dir / "once.tif", 360, 181, centres, world);
  expectSameWorldTiles(dir, "repeated", "once");
}

// ---------------------------------------------------------- nothing to make

TEST(Inputs, JobsThatMakeNothingSayWhyWithTheirExitCode) {
  const fs::path dir = caseDir();
  writeHills(dir / "void.tif", [](int, int) { return NAN; });
  const RunResult all_void = run(tileArgs(dir / "void.tif", dir / "out", "void"));
  EXPECT_EQ(all_void.exit_code, kExitNothingMade) << describe(all_void);
  EXPECT_TRUE(contains(all_void.err, "warning: no tile written")) << describe(all_void);

  const double polar[6] = {10, 0.01, 0, 89, 0, -0.01};
  writeDem(dir / "polar.tif", 100, 100, polar, hill);
  const RunResult beyond = run(tileArgs(dir / "polar.tif", dir / "out", "polar"));
  EXPECT_EQ(beyond.exit_code, kExitNothingMade) << describe(beyond);
  EXPECT_TRUE(contains(beyond.err, "beyond the latitudes webmercator tiles reach")) << describe(beyond);

  writeHills(dir / "dem.tif");
  std::vector<std::string> args = tileArgs(dir / "dem.tif", dir / "out", "box");
  args.insert(args.end(), {"--bbox", "20,40,21,41"});
  const RunResult box = run(args);
  EXPECT_EQ(box.exit_code, kExitNothingMade) << describe(box);
  EXPECT_TRUE(contains(box.err, "warning: tiling.bbox: lon 20 to 21, lat 40 to 41 does not overlap")) << describe(box);

  // A shard with no tile of its own is a success: the job has at most 2 tiles at zoom 10.
  std::vector<std::string> shard = tileArgs(dir / "dem.tif", dir / "out", "shard", "10");
  shard.insert(shard.end(), {"--shard", "5/5"});
  const RunResult empty_shard = run(shard);
  EXPECT_EQ(empty_shard.exit_code, kExitOk) << describe(empty_shard);
}

}  // namespace
}  // namespace terrabake

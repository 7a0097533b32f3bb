// Checks the test-side tools themselves, against hand-made data and
// independent routes (PROJ through GDAL, GeographicLib's LocalCartesian).
#include <OpenImageIO/imageio.h>
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/analytic_terrain.hpp"
#include "support/glb_reader.hpp"
#include "support/image_reader.hpp"
#include "test_helpers.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace terrabake::test_support;
using terrabake::test::writeBytes;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

double angleDeg(glm::dvec3 a, glm::dvec3 b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) / kDeg;
}

// A fresh directory per test, so tests may run in parallel.
fs::path scratchDir() {
  const auto* info = testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(testing::TempDir()) / "terrabake_support_test" /
                       (std::string(info->test_suite_name()) + "." + info->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

GDALDatasetUniquePtr openRaster(const fs::path& path) {
  GDALAllRegister();
  GDALDatasetUniquePtr dataset(GDALDataset::Open(path.string().c_str(), GDAL_OF_RASTER));
  if (!dataset) throw std::runtime_error("GDAL cannot open " + path.string());
  return dataset;
}

template <class T>
std::vector<T> readBand(GDALDataset& dataset, GDALDataType type) {
  const int width = dataset.GetRasterXSize();
  const int height = dataset.GetRasterYSize();
  std::vector<T> data(std::size_t(width) * height);
  EXPECT_EQ(dataset.GetRasterBand(1)->RasterIO(GF_Read, 0, 0, width, height, data.data(), width,
                                               height, type, 0, 0),
            CE_None);
  return data;
}

std::array<double, 6> geoTransform(GDALDataset& dataset) {
  std::array<double, 6> gt{};
  EXPECT_EQ(dataset.GetGeoTransform(gt.data()), CE_None);
  return gt;
}

std::string epsgCode(GDALDataset& dataset) {
  const OGRSpatialReference* srs = dataset.GetSpatialRef();
  if (!srs) return "";
  const char* code = srs->GetAuthorityCode(nullptr);
  return code ? code : "";
}

// ---------------------------------------------------------------- terrain

TEST(AnalyticTerrain, HeightsAndSlopesStayInTheirDesignedRanges) {
  const glm::dvec2 centre = utm33(15.2, 47.1);
  constexpr double kStep = 150.0;
  constexpr double kDerivativeStep = 0.01;
  int steep_enough = 0;
  int total = 0;
  for (double dn = -15000; dn <= 15000; dn += kStep) {
    for (double de = -15000; de <= 15000; de += kStep) {
      const double e = centre.x + de;
      const double n = centre.y + dn;
      const double h = heightUtm(e, n);
      ASSERT_GE(h, 200.0);
      ASSERT_LE(h, 1500.0);
      const double gx = (heightUtm(e + kDerivativeStep, n) - heightUtm(e - kDerivativeStep, n)) /
                        (2 * kDerivativeStep);
      const double gy = (heightUtm(e, n + kDerivativeStep) - heightUtm(e, n - kDerivativeStep)) /
                        (2 * kDerivativeStep);
      const double slope = std::atan(std::hypot(gx, gy)) / kDeg;
      steep_enough += slope >= 5.0 && slope <= 35.0;
      ++total;
    }
  }
  EXPECT_GT(double(steep_enough) / total, 0.9);
}

TEST(AnalyticTerrain, Utm33AgreesWithProj) {
  OGRSpatialReference wgs84;
  OGRSpatialReference utm;
  ASSERT_EQ(wgs84.importFromEPSG(4326), OGRERR_NONE);
  ASSERT_EQ(utm.importFromEPSG(32633), OGRERR_NONE);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_utm(
      OGRCreateCoordinateTransformation(&wgs84, &utm));
  ASSERT_TRUE(to_utm);
  for (const auto& [lon, lat] : std::vector<std::pair<double, double>>{
           {15.2, 47.1}, {13.0, 46.0}, {17.5, 48.5}, {10.0, 46.5}, {15.0, -10.0}}) {
    double x = lon;
    double y = lat;
    ASSERT_TRUE(to_utm->Transform(1, &x, &y));
    const glm::dvec2 p = utm33(lon, lat);
    EXPECT_NEAR(p.x, x, 1e-3) << lon << " " << lat;
    EXPECT_NEAR(p.y, y, 1e-3) << lon << " " << lat;
    EXPECT_DOUBLE_EQ(heightLonLat(lon, lat), heightUtm(p.x, p.y));
  }
}

TEST(AnalyticTerrain, NormalIsUnitAndPointsUp) {
  for (double lon = 14.9; lon <= 15.5; lon += 0.05) {
    for (double lat = 46.9; lat <= 47.3; lat += 0.05) {
      const glm::dvec3 n = normalEcef(lon, lat);
      EXPECT_NEAR(glm::length(n), 1.0, 1e-12);
      EXPECT_GT(glm::dot(n, ellipsoidUpEcef(lon, lat)), 0.5);
    }
  }
}

TEST(AnalyticTerrain, NormalMatchesASmallPlaneInLocalEnu) {
  constexpr double kDelta = 2e-5;  // about 2 m
  for (const auto& [lon, lat] : std::vector<std::pair<double, double>>{
           {15.2, 47.1}, {15.23, 47.08}, {14.7, 46.6}, {10.0, 46.5}}) {
    const GeographicLib::LocalCartesian enu(lat, lon, 0.0);
    auto local = [&](double lon_p, double lat_p) {
      glm::dvec3 p;
      enu.Forward(lat_p, lon_p, heightLonLat(lon_p, lat_p), p.x, p.y, p.z);
      return p;
    };
    const glm::dvec3 plane_normal =
        glm::normalize(glm::cross(local(lon + kDelta, lat) - local(lon - kDelta, lat),
                                  local(lon, lat + kDelta) - local(lon, lat - kDelta)));

    const glm::dvec3 east(-std::sin(lon * kDeg), std::cos(lon * kDeg), 0.0);
    const glm::dvec3 north(-std::sin(lat * kDeg) * std::cos(lon * kDeg),
                           -std::sin(lat * kDeg) * std::sin(lon * kDeg), std::cos(lat * kDeg));
    const glm::dvec3 up = ellipsoidUpEcef(lon, lat);
    const glm::dvec3 n = normalEcef(lon, lat);
    const glm::dvec3 n_enu(glm::dot(n, east), glm::dot(n, north), glm::dot(n, up));
    EXPECT_LT(angleDeg(n_enu, plane_normal), 1e-4) << lon << " " << lat;

    // Its tilt is the slope of heightUtm, up to UTM's scale factor (< 0.1%).
    const glm::dvec2 p = utm33(lon, lat);
    constexpr double kStep = 0.01;
    const double gx = (heightUtm(p.x + kStep, p.y) - heightUtm(p.x - kStep, p.y)) / (2 * kStep);
    const double gy = (heightUtm(p.x, p.y + kStep) - heightUtm(p.x, p.y - kStep)) / (2 * kStep);
    EXPECT_NEAR(angleDeg(n, up), std::atan(std::hypot(gx, gy)) / kDeg, 0.05);
  }
}

// ---------------------------------------------------------------- DEM writers

TEST(DemWriters, UtmDemReadsBackWithCrsGeotransformAndValues) {
  const fs::path path = scratchDir() / "utm.tif";
  writeUtmDem(path, 15.2, 47.1, 30.0, 64, 48);
  auto dataset = openRaster(path);
  ASSERT_EQ(dataset->GetRasterXSize(), 64);
  ASSERT_EQ(dataset->GetRasterYSize(), 48);
  EXPECT_EQ(dataset->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
  int has_nodata = 0;
  dataset->GetRasterBand(1)->GetNoDataValue(&has_nodata);
  EXPECT_FALSE(has_nodata);
  EXPECT_EQ(epsgCode(*dataset), "32633");

  const auto gt = geoTransform(*dataset);
  const glm::dvec2 centre = utm33(15.2, 47.1);
  EXPECT_DOUBLE_EQ(gt[1], 30.0);
  EXPECT_DOUBLE_EQ(gt[5], -30.0);
  EXPECT_EQ(gt[2], 0.0);
  EXPECT_EQ(gt[4], 0.0);
  EXPECT_NEAR(gt[0] + 32 * 30.0, centre.x, 1e-6);
  EXPECT_NEAR(gt[3] - 24 * 30.0, centre.y, 1e-6);

  const auto data = readBand<float>(*dataset, GDT_Float32);
  for (int row = 0; row < 48; row += 7) {
    for (int col = 0; col < 64; col += 9) {
      const double expected = heightUtm(gt[0] + (col + 0.5) * gt[1], gt[3] + (row + 0.5) * gt[5]);
      EXPECT_NEAR(data[std::size_t(row) * 64 + col], expected, 1e-3);
    }
  }
}

TEST(DemWriters, GeographicDemIsTheSameTerrainInLonLat) {
  const fs::path path = scratchDir() / "geographic.tif";
  writeGeographicDem(path, 15.2, 47.1, 0.0005, 0.0004, 40, 30);
  auto dataset = openRaster(path);
  ASSERT_EQ(dataset->GetRasterXSize(), 40);
  ASSERT_EQ(dataset->GetRasterYSize(), 30);
  EXPECT_EQ(dataset->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
  int has_nodata = 0;
  dataset->GetRasterBand(1)->GetNoDataValue(&has_nodata);
  EXPECT_FALSE(has_nodata);
  EXPECT_EQ(epsgCode(*dataset), "4326");

  const auto gt = geoTransform(*dataset);
  EXPECT_DOUBLE_EQ(gt[1], 0.0005);
  EXPECT_DOUBLE_EQ(gt[5], -0.0004);
  EXPECT_NEAR(gt[0] + 20 * 0.0005, 15.2, 1e-12);  // x is longitude
  EXPECT_NEAR(gt[3] - 15 * 0.0004, 47.1, 1e-12);

  // Through PROJ rather than utm33: each value is the UTM terrain's height there.
  OGRSpatialReference utm;
  ASSERT_EQ(utm.importFromEPSG(32633), OGRERR_NONE);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  OGRSpatialReference file_srs(*dataset->GetSpatialRef());
  file_srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_utm(
      OGRCreateCoordinateTransformation(&file_srs, &utm));
  ASSERT_TRUE(to_utm);
  const auto data = readBand<float>(*dataset, GDT_Float32);
  for (int row = 0; row < 30; row += 4) {
    for (int col = 0; col < 40; col += 6) {
      double x = gt[0] + (col + 0.5) * gt[1];
      double y = gt[3] + (row + 0.5) * gt[5];
      ASSERT_TRUE(to_utm->Transform(1, &x, &y));
      EXPECT_NEAR(data[std::size_t(row) * 40 + col], heightUtm(x, y), 1e-3);
    }
  }
}

TEST(DemWriters, BundledSampleDemIsTheGeneratorsOutput) {
  const fs::path stored = fs::path(TERRABAKE_SOURCE_DIR) / "tests/data/sample_dem.tif";
  ASSERT_TRUE(fs::exists(stored));
  EXPECT_LT(fs::file_size(stored), 2u * 1024 * 1024);
  auto dataset = openRaster(stored);
  ASSERT_EQ(dataset->GetRasterXSize(), 1024);
  ASSERT_EQ(dataset->GetRasterYSize(), 1024);
  GDALRasterBand* band = dataset->GetRasterBand(1);
  EXPECT_EQ(band->GetRasterDataType(), GDT_Int16);
  int has_nodata = 0;
  band->GetNoDataValue(&has_nodata);
  EXPECT_FALSE(has_nodata);
  int block_w = 0;
  int block_h = 0;
  band->GetBlockSize(&block_w, &block_h);
  EXPECT_EQ(block_h, block_w);  // tiled, not strips
  EXPECT_STREQ(dataset->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE"), "DEFLATE");
  EXPECT_EQ(epsgCode(*dataset), "32632");
  const auto gt = geoTransform(*dataset);
  EXPECT_DOUBLE_EQ(gt[1], 30.0);
  EXPECT_DOUBLE_EQ(gt[5], -30.0);

  OGRSpatialReference wgs84;
  ASSERT_EQ(wgs84.importFromEPSG(4326), OGRERR_NONE);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_lonlat(
      OGRCreateCoordinateTransformation(dataset->GetSpatialRef(), &wgs84));
  double x = gt[0] + 512 * gt[1];
  double y = gt[3] + 512 * gt[5];
  ASSERT_TRUE(to_lonlat && to_lonlat->Transform(1, &x, &y));
  EXPECT_NEAR(x, 10.0, 0.01);
  EXPECT_NEAR(y, 46.5, 0.01);

  const auto stored_data = readBand<int16_t>(*dataset, GDT_Int16);
  EXPECT_EQ(*std::min_element(stored_data.begin(), stored_data.end()), 400);
  EXPECT_EQ(*std::max_element(stored_data.begin(), stored_data.end()), 3500);

  const fs::path fresh = scratchDir() / "sample_dem.tif";
  writeSampleDem(fresh);
  auto fresh_dataset = openRaster(fresh);
  const auto fresh_data = readBand<int16_t>(*fresh_dataset, GDT_Int16);
  ASSERT_EQ(fresh_data.size(), stored_data.size());
  int max_difference = 0;
  for (std::size_t i = 0; i < fresh_data.size(); ++i) {
    max_difference = std::max(max_difference, std::abs(fresh_data[i] - stored_data[i]));
  }
  // 1 m of slack for a different compiler rounding a .5 the other way.
  EXPECT_LE(max_difference, 1);
}

// ---------------------------------------------------------------- GLB reader

void appendFloats(std::vector<uint8_t>& bin, std::initializer_list<float> values) {
  for (float v : values) {
    uint8_t bytes[4];
    std::memcpy(bytes, &v, 4);
    bin.insert(bin.end(), bytes, bytes + 4);
  }
}

// GLB container around a glTF JSON and a BIN payload, padded as the spec says.
std::vector<uint8_t> assembleGlb(const json& gltf, std::vector<uint8_t> bin) {
  std::string text = gltf.dump();
  text.resize((text.size() + 3) / 4 * 4, ' ');
  bin.resize((bin.size() + 3) / 4 * 4, 0);
  std::vector<uint8_t> out;
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
  };
  u32(0x46546C67);
  u32(2);
  u32(uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  u32(uint32_t(text.size()));
  u32(0x4E4F534A);
  out.insert(out.end(), text.begin(), text.end());
  u32(uint32_t(bin.size()));
  u32(0x004E4942);
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

// A flat 2 m x 2 m quad, UV (0, 0) at its north-west corner. The indices come
// first, behind 4 bytes of padding the accessor skips; the vertex attributes
// are interleaved (position, normal, tangent, uv: 48 bytes a vertex).
struct QuadGlb {
  json gltf;
  std::vector<uint8_t> bin;
};

QuadGlb quadGlb(bool uint32_indices, float tangent_w) {
  QuadGlb quad;
  std::vector<uint8_t>& bin = quad.bin;
  const std::vector<uint32_t> indices = {0, 2, 1, 1, 2, 3};
  bin.assign(4, 0xAB);
  for (uint32_t index : indices) {
    const int size = uint32_indices ? 4 : 2;
    for (int i = 0; i < size; ++i) bin.push_back(uint8_t(index >> (8 * i)));
  }
  const std::size_t index_bytes = bin.size();
  bin.resize((bin.size() + 3) / 4 * 4, 0);
  const std::size_t vertex_offset = bin.size();
  const float corners[4][4] = {
      {-1, -1, 0, 0}, {1, -1, 1, 0}, {-1, 1, 0, 1}, {1, 1, 1, 1}};  // x, z, u, v
  for (const auto& c : corners) {
    appendFloats(bin,
                 {c[0], 0.0f, c[1], 0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 0.0f, tangent_w, c[2], c[3]});
  }
  const std::size_t vertex_bytes = bin.size() - vertex_offset;

  quad.gltf = {
      {"asset",
       {{"version", "2.0"},
        {"extras",
         {{"terrabake",
           {{"origin", {15.25, 47.125, 0}},
            {"enu_to_ecef", {1, 2, 3, 0, 4, 5, 6, 0, 7, 8, 9, 0, 10, 11, 12, 1}}}}}}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 1}, {"NORMAL", 2}, {"TANGENT", 3}, {"TEXCOORD_0", 4}}},
            {"indices", 0},
            {"material", 0},
            {"mode", 4}}}}}}},
      {"materials", {{{"normalTexture", {{"index", 0}}}}}},
      {"textures", {{{"source", 0}}}},
      {"images", {{{"uri", "7.png"}}}},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", index_bytes}},
        {{"buffer", 0},
         {"byteOffset", vertex_offset},
         {"byteLength", vertex_bytes},
         {"byteStride", 48}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"byteOffset", 4},
         {"componentType", uint32_indices ? 5125 : 5123},
         {"count", 6},
         {"type", "SCALAR"}},
        {{"bufferView", 1},
         {"byteOffset", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {-1, 0, -1}},
         {"max", {1, 0, 1}}},
        {{"bufferView", 1},
         {"byteOffset", 12},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"}},
        {{"bufferView", 1},
         {"byteOffset", 24},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC4"}},
        {{"bufferView", 1},
         {"byteOffset", 40},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC2"}}}},
  };
  return quad;
}

GlbMesh readQuad(const QuadGlb& quad) {
  const fs::path path = scratchDir() / "quad.glb";
  writeBytes(path, assembleGlb(quad.gltf, quad.bin));
  return readGlb(path);
}

TEST(GlbReader, ReadsInterleavedAttributesAndShortIndices) {
  const GlbMesh mesh = readQuad(quadGlb(false, 1.0f));
  ASSERT_EQ(mesh.position.size(), 4u);
  EXPECT_EQ(mesh.position[1], glm::dvec3(1, 0, -1));
  EXPECT_EQ(mesh.position[2], glm::dvec3(-1, 0, 1));
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(mesh.normal[i], glm::dvec3(0, 1, 0));
    EXPECT_EQ(mesh.tangent[i], glm::dvec4(1, 0, 0, 1));
  }
  EXPECT_EQ(mesh.uv[0], glm::dvec2(0, 0));
  EXPECT_EQ(mesh.uv[3], glm::dvec2(1, 1));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 2, 1, 1, 2, 3}));
  EXPECT_EQ(mesh.image_uri, "7.png");
  EXPECT_EQ(mesh.origin_lon, 15.25);
  EXPECT_EQ(mesh.origin_lat, 47.125);
  EXPECT_EQ(mesh.enu_to_ecef[4], 4.0);
  EXPECT_EQ(mesh.enu_to_ecef[15], 1.0);
  EXPECT_EQ(mesh.json.at("asset").at("version"), "2.0");
}

TEST(GlbReader, ReadsIntIndices) {
  const GlbMesh mesh = readQuad(quadGlb(true, 1.0f));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 2, 1, 1, 2, 3}));
}

TEST(GlbReader, RejectsMalformedFiles) {
  const QuadGlb good = quadGlb(false, 1.0f);
  const fs::path dir = scratchDir();
  // Each must fail for its own reason, named in the message.
  auto expectThrow = [&](const std::vector<uint8_t>& bytes, const std::string& reason) {
    const fs::path path = dir / "bad.glb";
    writeBytes(path, bytes);
    try {
      readGlb(path);
      ADD_FAILURE() << "no exception, expected: " << reason;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  const std::vector<uint8_t> bytes = assembleGlb(good.gltf, good.bin);

  std::vector<uint8_t> bad_magic = bytes;
  bad_magic[0] = 'x';
  expectThrow(bad_magic, "not a GLB");
  expectThrow(std::vector<uint8_t>(bytes.begin(), bytes.end() - 8), "length does not match");
  std::vector<uint8_t> bad_json = bytes;
  bad_json[20] = '#';
  expectThrow(bad_json, "parse error");

  QuadGlb overrun = good;
  overrun.gltf["accessors"][4]["count"] = 5;
  expectThrow(assembleGlb(overrun.gltf, overrun.bin), "overruns its bufferView");
  QuadGlb no_tangent = good;
  no_tangent.gltf["meshes"][0]["primitives"][0]["attributes"].erase("TANGENT");
  expectThrow(assembleGlb(no_tangent.gltf, no_tangent.bin), "no TANGENT");
  QuadGlb bad_index = good;
  bad_index.bin[4] = 9;
  expectThrow(assembleGlb(bad_index.gltf, bad_index.bin), "out of range");
  QuadGlb no_extras = good;
  no_extras.gltf["asset"].erase("extras");
  expectThrow(assembleGlb(no_extras.gltf, no_extras.bin), "extras");
  expectThrow({}, "not a GLB");
}

TEST(GlbReader, DecodesTangentSpaceLikeARenderer) {
  const GlbMesh mesh = readQuad(quadGlb(false, 1.0f));
  const glm::dvec2 uv(0.3, 0.6);
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, uv, {0, 0, 1}), {0, 1, 0}), 1e-9);
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, uv, {1, 0, 0}), {1, 0, 0}), 1e-9);
  // Green up is north, which is -Z in glTF axes.
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, uv, {0, 1, 0}), {0, 0, -1}), 1e-9);
  // The stored "flat" texel decodes at the 8-bit floor of about 0.32 degrees.
  const glm::dvec3 flat = *decodeWorldNormal(mesh, uv, decodeRgb(128, 128, 255, 8));
  EXPECT_NEAR(angleDeg(flat, {0, 1, 0}), 0.318, 0.01);
  // On the shared diagonal, on the border, and off the mesh.
  EXPECT_TRUE(decodeWorldNormal(mesh, {0.5, 0.5}, {0, 0, 1}));
  EXPECT_TRUE(decodeWorldNormal(mesh, {1.0, 0.25}, {0, 0, 1}));
  EXPECT_TRUE(decodeWorldNormal(mesh, {0.0, 0.0}, {0, 0, 1}));
  EXPECT_FALSE(decodeWorldNormal(mesh, {1.01, 0.5}, {0, 0, 1}));
}

TEST(GlbReader, NegativeTangentWFlipsTheBitangent) {
  const GlbMesh mesh = readQuad(quadGlb(false, -1.0f));
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, {0.7, 0.2}, {0, 1, 0}), {0, 0, 1}), 1e-9);
}

TEST(GlbReader, InterpolatesNormalAndTangentBarycentrically) {
  GlbMesh mesh = readQuad(quadGlb(false, 1.0f));
  mesh.normal[1] = glm::normalize(glm::dvec3(1, 1, 0));
  mesh.tangent[1] = glm::dvec4(glm::normalize(glm::dvec3(1, -1, 0)), 1);
  // At a vertex, the vertex's own frame.
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, {1, 0}, {0, 0, 1}), mesh.normal[1]), 1e-9);
  // Halfway along the north edge (vertices 0 and 1), the normalised mean.
  const glm::dvec3 mid_normal = glm::normalize(glm::dvec3(0, 1, 0) + mesh.normal[1]);
  const glm::dvec3 mid_tangent = glm::normalize(glm::dvec3(1, 0, 0) + glm::dvec3(mesh.tangent[1]));
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, {0.5, 0}, {0, 0, 1}), mid_normal), 1e-9);
  EXPECT_LT(angleDeg(*decodeWorldNormal(mesh, {0.5, 0}, {1, 0, 0}), mid_tangent), 1e-9);

  mesh.indices.resize(3);
  EXPECT_THROW(decodeWorldNormal(mesh, {0.2, 0.2}, {0, 0, 1}), std::logic_error);
  indexUv(mesh);
  EXPECT_TRUE(decodeWorldNormal(mesh, {0.2, 0.2}, {0, 0, 1}));
  EXPECT_FALSE(decodeWorldNormal(mesh, {0.8, 0.8}, {0, 0, 1}));
}

TEST(GlbReader, MapsLocalCoordinatesToEcef) {
  constexpr double kLon = 15.25;
  constexpr double kLat = 47.125;
  GlbMesh mesh;
  glm::dvec3 origin;
  GeographicLib::Geocentric::WGS84().Forward(kLat, kLon, 0.0, origin.x, origin.y, origin.z);
  const glm::dvec3 east(-std::sin(kLon * kDeg), std::cos(kLon * kDeg), 0.0);
  const glm::dvec3 up = ellipsoidUpEcef(kLon, kLat);
  const glm::dvec3 south = glm::cross(east, up);
  const glm::dvec3 columns[4] = {east, up, south, origin};
  for (int col = 0; col < 4; ++col) {
    for (int row = 0; row < 3; ++row) mesh.enu_to_ecef[4 * col + row] = columns[col][row];
    mesh.enu_to_ecef[4 * col + 3] = col == 3 ? 1.0 : 0.0;
  }
  EXPECT_LT(glm::length(localToEcefDirection(mesh, {0, 1, 0}) - up), 1e-15);
  EXPECT_LT(glm::length(localToEcefDirection(mesh, {0, 0, -1}) + south), 1e-15);
  glm::dvec3 above;
  GeographicLib::Geocentric::WGS84().Forward(kLat, kLon, 100.0, above.x, above.y, above.z);
  EXPECT_LT(glm::length(localToEcefPoint(mesh, {0, 100, 0}) - above), 1e-6);
}

// ---------------------------------------------------------------- PNG reader

template <class T>
void writePng(const fs::path& path, int width, int height, OIIO::TypeDesc type,
              const std::vector<T>& pixels) {
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(path.string(), OIIO::ImageSpec(width, height, 3, type)));
  ASSERT_TRUE(out->write_image(type, pixels.data()));
  ASSERT_TRUE(out->close());
}

TEST(ImageReader, Reads8BitSamplesExactly) {
  const fs::path path = scratchDir() / "rgb8.png";
  const std::vector<uint8_t> pixels = {0,  128, 255, 1,  2,  3,  254, 127, 129,
                                       10, 20,  30,  40, 50, 60, 70,  80,  90};
  writePng(path, 3, 2, OIIO::TypeDesc::UINT8, pixels);
  const PngImage image = readPng(path);
  EXPECT_EQ(image.width, 3);
  EXPECT_EQ(image.height, 2);
  EXPECT_EQ(image.channels, 3);
  EXPECT_EQ(image.bits, 8);
  ASSERT_EQ(image.samples.size(), pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i) EXPECT_EQ(image.samples[i], pixels[i]);
  EXPECT_EQ(image.sample(2, 0, 1), 127);
  EXPECT_EQ(image.sample(0, 1, 2), 30);

  const auto chunks = pngChunkTypes(path);
  ASSERT_FALSE(chunks.empty());
  EXPECT_EQ(chunks.front(), "IHDR");
  EXPECT_EQ(chunks.back(), "IEND");
  EXPECT_NE(std::find(chunks.begin(), chunks.end(), "IDAT"), chunks.end());
}

TEST(ImageReader, Reads16BitSamplesExactly) {
  const fs::path path = scratchDir() / "rgb16.png";
  const std::vector<uint16_t> pixels = {0, 32768, 65535, 1, 256, 65534};
  writePng(path, 2, 1, OIIO::TypeDesc::UINT16, pixels);
  const PngImage image = readPng(path);
  EXPECT_EQ(image.bits, 16);
  ASSERT_EQ(image.samples.size(), pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i) EXPECT_EQ(image.samples[i], pixels[i]);
}

TEST(ImageReader, RejectsNonPng) {
  const fs::path path = scratchDir() / "not.png";
  std::ofstream(path) << "hello";
  EXPECT_THROW(readPng(path), std::runtime_error);
  EXPECT_THROW(pngChunkTypes(path), std::runtime_error);
}

TEST(ImageReader, DecodesRgbToTangentSpace) {
  EXPECT_EQ(decodeRgb(255, 0, 255, 8), glm::dvec3(1, -1, 1));
  EXPECT_EQ(decodeRgb(65535, 0, 65535, 16), glm::dvec3(1, -1, 1));
  const glm::dvec3 mid = decodeRgb(128, 128, 128, 8);
  EXPECT_DOUBLE_EQ(mid.x, 1.0 / 255.0);
  EXPECT_DOUBLE_EQ(decodeRgb(0, 32768, 0, 16).y, 1.0 / 65535.0);
  EXPECT_EQ(decodeRgb(10, 200, 30, 8, false).y, -decodeRgb(10, 200, 30, 8).y);
  EXPECT_EQ(decodeRgb(10, 200, 30, 8, false).x, decodeRgb(10, 200, 30, 8).x);
}

}  // namespace

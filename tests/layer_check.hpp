#pragma once
// Runs tile jobs into the test output folder and decodes what they wrote the
// way a glTF renderer would (tests/support), for tests that judge layers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <memory>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "config/tile_job.hpp"
#include "core/types.hpp"
#include "pipeline/tile_job_runner.hpp"
#include "support/analytic_terrain.hpp"
#include "support/glb_reader.hpp"
#include "support/image_reader.hpp"
#include "test_helpers.hpp"

namespace terrabake::test {

// The analytic terrain of tests/support as a DEM: `pixels` x `pixels` pixels
// of 30 m in UTM zone 33N around 15.3 E, 60 N. The file name holds every
// setting, so each size is made once per run whichever test asks first.
inline std::filesystem::path analyticUtmDem(int pixels) {
  return sharedFixture("analytic_utm33_" + std::to_string(pixels) + ".tif", [pixels](const std::filesystem::path& path) {
    test_support::writeUtmDem(path, 15.3, 60.0, 30.0, pixels, pixels);
  });
}

// The small DEM of the serve and MBTiles tests: 128 x 128 pixels, a few tiles at zooms 11-13.
inline std::filesystem::path smallDem() { return analyticUtmDem(128); }

inline config::TileJob tileJob(const std::filesystem::path& dem, const std::string& out_name,
                               SchemeKind scheme, int min_zoom, int max_zoom) {
  config::TileJob job;
  job.dems = {dem.string()};
  job.output_dir = testOutput(out_name).string();
  job.layer = "layer";
  job.scheme = scheme;
  job.min_zoom = min_zoom;
  job.max_zoom = max_zoom;
  job.zoom_set = true;
  job.workers = 2;
  return job;
}

inline std::filesystem::path layerDir(const config::TileJob& job) {
  return std::filesystem::path(job.output_dir) / job.layer;
}

// A tile read back from disk: its normal map and its mesh.
struct DecodedTile {
  test_support::PngImage png;
  test_support::GlbMesh glb;
  bool green_up = true;

  // World normal in ECEF a renderer shows at texel (i, j); empty if the
  // texel's UV lies on no triangle (a defect the caller reports).
  std::optional<glm::dvec3> ecefNormal(int i, int j) const {
    const glm::dvec2 uv((i + 0.5) / png.width, (j + 0.5) / png.height);
    const glm::dvec3 t = test_support::decodeRgb(png.sample(i, j, 0), png.sample(i, j, 1),
                                                 png.sample(i, j, 2), png.bits, green_up);
    const auto local = test_support::decodeWorldNormal(glb, uv, t);
    if (!local) return std::nullopt;
    return glm::normalize(test_support::localToEcefDirection(glb, *local));
  }
};

inline DecodedTile readTile(const std::filesystem::path& layer, const TileId& tile) {
  const auto base = layer / std::to_string(tile.z) / std::to_string(tile.x) / std::to_string(tile.y);
  return {test_support::readPng(base.string() + ".png"), test_support::readGlb(base.string() + ".glb")};
}

// Count, mean, 99th percentile and maximum of a set of values (angles, steps).
struct Stats {
  std::size_t count = 0;
  double mean = 0, p99 = 0, max = 0;
};

inline Stats summarise(std::vector<double> values) {
  Stats s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / double(values.size());
  s.p99 = values[std::min(values.size() - 1, std::size_t(double(values.size()) * 0.99))];
  s.max = values.back();
  return s;
}

inline double angleBetweenDeg(const glm::dvec3& a, const glm::dvec3& b) {
  const double c = glm::dot(glm::normalize(a), glm::normalize(b));
  return std::acos(std::min(1.0, std::max(-1.0, c))) * 180.0 / M_PI;
}

// Web Mercator texel centre to longitude / latitude (spherical formulas).
inline glm::dvec2 webMercatorTexelLonLat(const TileId& tile, int tile_size, double i, double j) {
  constexpr double kRadius = 6378137.0;
  const double world = 2 * M_PI * kRadius, tile_m = world / (1 << tile.z);
  const double x = -world / 2 + (tile.x + (i + 0.5) / tile_size) * tile_m;
  const double y = world / 2 - (tile.y + (j + 0.5) / tile_size) * tile_m;
  return {x / kRadius * 180 / M_PI, std::atan(std::sinh(y / kRadius)) * 180 / M_PI};
}

// Geodetic (EPSG:4326, TMS rows) texel centre to longitude / latitude.
inline glm::dvec2 geodeticTexelLonLat(const TileId& tile, int tile_size, double i, double j) {
  const double tile_deg = 180.0 / (1 << tile.z);
  return {-180 + (tile.x + (i + 0.5) / tile_size) * tile_deg, -90 + (tile.y + 1 - (j + 0.5) / tile_size) * tile_deg};
}

// The DEM's pixel grid, for locating texels with GDAL, not with terrabake.
class DemGeometry {
 public:
  explicit DemGeometry(const std::filesystem::path& path) {
    GDALAllRegister();
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER));
    ds->GetGeoTransform(m_gt);
    m_width = ds->GetRasterXSize();
    m_height = ds->GetRasterYSize();
    OGRSpatialReference wgs84;
    wgs84.importFromEPSG(4326);
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    OGRSpatialReference dem_srs(*ds->GetSpatialRef());
    dem_srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    m_to_dem.reset(OGRCreateCoordinateTransformation(&wgs84, &dem_srs));
    m_to_lon_lat.reset(OGRCreateCoordinateTransformation(&dem_srs, &wgs84));
  }

  // Pixel (fractional, centre of pixel 0 at 0.5) of a lon/lat point.
  glm::dvec2 pixelOf(glm::dvec2 lon_lat) const {
    double x = lon_lat.x, y = lon_lat.y;
    m_to_dem->Transform(1, &x, &y);
    return {(x - m_gt[0]) / m_gt[1], (y - m_gt[3]) / m_gt[5]};
  }
  glm::dvec2 lonLatOfPixel(double col, double row) const {
    double x = m_gt[0] + col * m_gt[1], y = m_gt[3] + row * m_gt[5];
    m_to_lon_lat->Transform(1, &x, &y);
    return {x, y};
  }
  bool wellInside(glm::dvec2 px, double margin_px) const {
    return px.x > margin_px && px.y > margin_px && px.x < m_width - margin_px && px.y < m_height - margin_px;
  }

 private:
  double m_gt[6] = {};
  int m_width = 0, m_height = 0;
  std::unique_ptr<OGRCoordinateTransformation> m_to_dem, m_to_lon_lat;
};

// Neighbouring meshes meet (docs/CONTRACT.md §5): the same edge vertices, at
// the same ECEF point, with the same normal and tangent.
// docs/CONTRACT.md §5: edge vertices of neighbours coincide to 1 mm in ECEF,
// or to float32's relative precision over a larger tile's extent: each
// tile rounds its own local coordinates (up to half a tile) to float32, a
// relative error of 2^-24 per axis, sqrt(3) of it in length, on both sides.
constexpr double kMaxEdgeGapM = 1e-3;
const double kFloat32EdgeGapShare = 2 * std::sqrt(3.0) * std::ldexp(1.0, -24);
// Edge normals and tangents are computed in double from the same samples and
// stored as float32 unit vectors in each tile's own frame: 1e-3 degrees is
// about a hundred float32 roundings.
constexpr double kMaxEdgeFrameAngleDeg = 1e-3;
struct EdgeVertex {
  glm::dvec3 position, normal, tangent;
  double largest_local_coordinate;  // of the position in its tile's frame
};

// Vertices of `mesh` on its edge u == edge_uv (along_u false) or v == edge_uv,
// in ECEF, ordered along the edge.
inline std::vector<EdgeVertex> edgeVertices(const test_support::GlbMesh& mesh, bool vertical_edge, double edge_uv) {
  std::vector<std::pair<double, EdgeVertex>> found;
  for (std::size_t k = 0; k < mesh.uv.size(); ++k) {
    const double across = vertical_edge ? mesh.uv[k].x : mesh.uv[k].y;
    const double along = vertical_edge ? mesh.uv[k].y : mesh.uv[k].x;
    if (std::abs(across - edge_uv) > 1e-6) continue;
    found.push_back({along,
                     {test_support::localToEcefPoint(mesh, mesh.position[k]),
                      test_support::localToEcefDirection(mesh, mesh.normal[k]),
                      test_support::localToEcefDirection(mesh, glm::dvec3(mesh.tangent[k])),
                      std::max({std::abs(double(mesh.position[k].x)), std::abs(double(mesh.position[k].y)),
                                std::abs(double(mesh.position[k].z))})}});
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<EdgeVertex> result;
  for (auto& f : found) result.push_back(f.second);
  return result;
}

inline void expectSharedEdge(const test_support::GlbMesh& a, const test_support::GlbMesh& b, bool vertical_edge) {
  // a lies west (or north) of b: a's u (v) = 1 edge meets b's u (v) = 0 edge.
  const auto ea = edgeVertices(a, vertical_edge, 1.0), eb = edgeVertices(b, vertical_edge, 0.0);
  ASSERT_EQ(ea.size(), eb.size());
  ASSERT_GE(ea.size(), 2u);
  for (std::size_t k = 0; k < ea.size(); ++k) {
    const double largest = std::max(ea[k].largest_local_coordinate, eb[k].largest_local_coordinate);
    EXPECT_LE(glm::length(ea[k].position - eb[k].position), std::max(kMaxEdgeGapM, kFloat32EdgeGapShare * largest))
        << "edge vertex " << k;
    EXPECT_LE(angleBetweenDeg(ea[k].normal, eb[k].normal), kMaxEdgeFrameAngleDeg) << "edge vertex " << k;
    EXPECT_LE(angleBetweenDeg(ea[k].tangent, eb[k].tangent), kMaxEdgeFrameAngleDeg) << "edge vertex " << k;
  }
}

}  // namespace terrabake::test

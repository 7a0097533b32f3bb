// Adaptive low-poly meshes in whole layers, judged from the files alone: every
// height sample (the vertices of {y}.hires.glb) is within the bound of the
// low-poly surface at its UV, and neighbouring tiles share their edge
// vertices exactly, in every scheme, on a DEM with flat and rough parts side
// by side.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;

// Both meshes store float32 positions in the tile's frame: on tiles up to
// about 20 km across each rounds a point by under 1e-3 m.
constexpr double kFloat32SlackM = 2e-3;

constexpr double kCentreLon = 15.3, kCentreLat = 60.0;

fs::path flatAndRoughDem() {
  return test::sharedFixture("flat_and_rough_utm33_384.tif", [](const fs::path& path) {
    ts::writeFlatAndRoughUtmDem(path, kCentreLon, kCentreLat, 30.0, 384, 384);
  });
}

nlohmann::json readJson(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return nlohmann::json::parse(text.str());
}

// Every tile of a layer, by zoom, x and y, read from the folder.
std::map<TileId, ts::GlbMesh> readMeshes(const fs::path& layer) {
  std::map<TileId, ts::GlbMesh> meshes;
  for (const auto& zoom : fs::directory_iterator(layer)) {
    if (!zoom.is_directory()) continue;
    for (const auto& column : fs::directory_iterator(zoom.path())) {
      for (const auto& file : fs::directory_iterator(column.path())) {
        const std::string name = file.path().filename().string();
        if (name.size() < 5 || name.substr(name.size() - 4) != ".glb" || name.find(".hires") != std::string::npos) {
          continue;
        }
        const TileId id{std::stoi(zoom.path().filename().string()), std::stoi(column.path().filename().string()),
                        std::stoi(file.path().stem().string())};
        meshes[id] = ts::readGlb(file.path());
      }
    }
  }
  return meshes;
}

struct BoundCase {
  std::string name;
  std::function<fs::path()> dem;
  int min_zoom, max_zoom;
  double max_error_m;  // 0: the per-zoom default
};

class AdaptiveBoundInLayers : public ::testing::TestWithParam<BoundCase> {};

TEST_P(AdaptiveBoundInLayers, EverySampleOfEveryTileIsWithinTheBound) {
  const BoundCase& c = GetParam();
  config::TileJob job = test::tileJob(c.dem(), "adaptive_bound/" + c.name, SchemeKind::kWebMercator, c.min_zoom, c.max_zoom);
  job.max_error_m = c.max_error_m;
  job.high_res_mesh = true;
  job.backend = Backend::kCpu;
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const fs::path layer = test::layerDir(job);
  const auto bounds = readJson(layer / "tilejson.json")["terrabake"]["low_poly"]["max_error_m"];
  const auto meshes = readMeshes(layer);
  ASSERT_FALSE(meshes.empty());
  for (const auto& [id, low] : meshes) {
    const double bound = bounds.at(std::to_string(id.z)).get<double>();
    if (c.max_error_m > 0) {
      EXPECT_EQ(bound, c.max_error_m);
    }
    const fs::path base = layer / std::to_string(id.z) / std::to_string(id.x) / std::to_string(id.y);
    const ts::GlbMesh samples = ts::readGlb(base.string() + ".hires.glb", false);
    const double recorded = low.json["asset"]["extras"]["terrabake"]["max_error_m"].get<double>();
    EXPECT_LE(recorded, bound);
    double worst = 0;
    for (std::size_t k = 0; k < samples.uv.size(); ++k) {
      const glm::dvec2 uv = samples.uv[k];
      if (uv.x >= 1 || uv.y >= 1) continue;  // the next tile's first samples
      const auto surface = ts::surfacePointAt(low, uv);
      ASSERT_TRUE(surface) << "uv " << uv.x << ", " << uv.y << " on no triangle";
      worst = std::max(worst, glm::distance(*surface, samples.position[k]));
    }
    EXPECT_LE(worst, bound + kFloat32SlackM) << id.z << "/" << id.x << "/" << id.y;
    EXPECT_NEAR(worst, recorded, kFloat32SlackM) << id.z << "/" << id.x << "/" << id.y;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Dems, AdaptiveBoundInLayers,
    ::testing::Values(BoundCase{"sample_per_zoom",
                                [] { return fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif"; },
                                11, 12, 0},
                      BoundCase{"analytic_5m", [] { return test::analyticUtmDem(256); }, 13, 13, 5.0},
                      BoundCase{"flat_and_rough_2m", flatAndRoughDem, 13, 13, 2.0}),
    [](const auto& test_info) { return test_info.param.name; });

struct CrackCase {
  SchemeKind scheme;
  int min_zoom, max_zoom;
};

class AdaptiveCracks : public ::testing::TestWithParam<CrackCase> {};

TEST_P(AdaptiveCracks, NeighboursShareEveryEdgeVertex) {
  const CrackCase& c = GetParam();
  const std::string name(wordOf(c.scheme));
  config::TileJob job = test::tileJob(flatAndRoughDem(), "adaptive_cracks/" + name, c.scheme, c.min_zoom, c.max_zoom);
  job.tile_size = 128;
  job.max_zoom_auto = c.scheme == SchemeKind::kNative;  // every level of the DEM's own pyramid
  job.max_error_m = 1.0;
  job.backend = Backend::kCpu;
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const auto meshes = readMeshes(test::layerDir(job));
  // y grows southward in XYZ rows, northward in TMS rows (geodetic).
  const int south_step = c.scheme == SchemeKind::kGeodetic ? -1 : 1;
  int edges = 0, flat_edges = 0, rough_edges = 0;
  for (const auto& [id, mesh] : meshes) {
    const auto east = meshes.find({id.z, id.x + 1, id.y});
    const auto south = meshes.find({id.z, id.x, id.y + south_step});
    if (east != meshes.end()) {
      SCOPED_TRACE(std::to_string(id.z) + "/" + std::to_string(id.x) + "/" + std::to_string(id.y) + " east");
      test::expectSharedEdge(mesh, east->second, true);
      ++edges;
    }
    if (south != meshes.end()) {
      SCOPED_TRACE(std::to_string(id.z) + "/" + std::to_string(id.x) + "/" + std::to_string(id.y) + " south");
      test::expectSharedEdge(mesh, south->second, false);
      ++edges;
      // Edges of only their corners lie on the plain; those with many vertices cross the ridges.
      const std::size_t on_edge = test::edgeVertices(mesh, false, 1.0).size();
      flat_edges += on_edge == 2;
      rough_edges += on_edge > 10;
    }
  }
  std::printf("%s: %zu tiles, %d shared edges (%d flat, %d rough)\n", name.c_str(), meshes.size(), edges, flat_edges,
              rough_edges);
  EXPECT_GE(edges, 8);
  EXPECT_GE(flat_edges, 1);
  EXPECT_GE(rough_edges, 1);
}

INSTANTIATE_TEST_SUITE_P(Schemes, AdaptiveCracks,
                         ::testing::Values(CrackCase{SchemeKind::kWebMercator, 12, 14},
                                           CrackCase{SchemeKind::kGeodetic, 12, 13},
                                           CrackCase{SchemeKind::kNative, 0, 0}),
                         [](const auto& test_info) { return std::string(wordOf(test_info.param.scheme)); });

}  // namespace
}  // namespace terrabake

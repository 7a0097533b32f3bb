// A layer's 3D Tiles (docs/CONTRACT.md §8), judged from the files alone the
// way a 3D Tiles viewer reads them (tileset_walk.hpp): every content URI
// resolves, each tile's bounding volume holds every point of its own mesh
// and of those below it (a region its children's regions), geometricError
// falls strictly down the tree, and the transforms
// composed from the root place each mesh where its enu_to_ecef says. The
// pyramid is deep enough to continue in external tilesets. Across the
// antimeridian, boxes. Skirts: walls of the stated
// depth under the tile's border, facing out, shaded like the edge above.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "io/mbtiles.hpp"
#include "io/tileset.hpp"
#include "layer_check.hpp"
#include "mesh/skirt.hpp"
#include "tileset_walk.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Zooms 8 to 14: seven levels, one more than a tileset file holds.
constexpr int kMinZoom = 8, kMaxZoom = 14;
static_assert(kMaxZoom - kMinZoom >= io::kTilesetLevelsPerFile);

// A batch run's region holds its meshes' heights exactly (the ceiling to the
// millimetre of float32 vertices) and is widened below them only by how far
// a straight edge across the tile can bow on the curved earth: at most the
// chord sag d^2 / 8R of the shallowest tile's diagonal, here a zoom-8 Web
// Mercator tile at the DEM's 60° N (78 km a side, 240 m), with a quarter
// more for the tile's span of latitudes and the ellipsoid's curvature.
constexpr double kCeilingSlackM = 0.01;
double floorSlackM() {
  const double side_m = 2 * M_PI * 6378137.0 * std::cos(60.0 * M_PI / 180) / double(1 << kMinZoom);
  const double diagonal_m = std::sqrt(2.0) * side_m;
  return 1.25 * diagonal_m * diagonal_m / (8 * 6371000.0);
}

json readJson(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

// The walk over the layer folder's files.
test::TilesetWalk folderWalk(const fs::path& layer, int deepest_zoom = kMaxZoom) {
  return test::TilesetWalk(layer, deepest_zoom, [layer](const std::string& path) -> std::optional<std::string> {
    if (!fs::is_regular_file(layer / path)) return std::nullopt;
    return test::readBytes(layer / path);
  });
}

config::TileJob tilesetJob(const std::string& name) {
  config::TileJob job = test::tileJob(test::smallDem(), "tileset/" + name, SchemeKind::kWebMercator, kMinZoom, kMaxZoom);
  job.tile_size = 32;
  job.tileset = true;
  job.backend = Backend::kCpu;
  return job;
}

TEST(Tileset, FollowsTheStructuralRulesOf3DTiles) {
  const config::TileJob job = tilesetJob("structure");
  fs::remove_all(test::layerDir(job));
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const fs::path layer = test::layerDir(job);

  test::TilesetWalk walk = folderWalk(layer);
  walk.run();
  EXPECT_GT(walk.external_tilesets, 0) << "seven levels continue in external tilesets";
  EXPECT_EQ(walk.deepest_leaf_errors_nonzero, 0) << "the deepest zoom's tiles are the terrain itself";
  const std::set<TileId> on_disk = test::meshesOnDisk(layer);
  ASSERT_FALSE(on_disk.empty());
  for (const TileId& id : on_disk) EXPECT_EQ(walk.meshes_seen[id], 1) << id.str() << " is not in the tileset once";
  EXPECT_EQ(walk.meshes_seen.size(), on_disk.size());
  RecordProperty("loosest_floor_m", std::to_string(walk.loosest_floor_m));
  RecordProperty("loosest_ceiling_m", std::to_string(walk.loosest_ceiling_m));
  EXPECT_LT(walk.loosest_ceiling_m, kCeilingSlackM) << "a region's ceiling is its meshes' highest point";
  EXPECT_LT(walk.loosest_floor_m, floorSlackM()) << "a region's floor lies a chord's sag below its meshes at most";

  const json tilejson = readJson(layer / "tilejson.json");
  EXPECT_EQ(tilejson["terrabake"]["tileset"], "./tileset.json");
  EXPECT_EQ(tilejson["terrabake"]["low_poly"]["skirts"], true) << "skirts are on by default in a tileset";
}

TEST(Tileset, ShardsAndMbtilesHoldTheSameTileset) {
  const config::TileJob whole = tilesetJob("whole");
  fs::remove_all(test::layerDir(whole));
  ASSERT_EQ(pipeline::runTileJob(whole).failed, 0);
  const std::string expected = test::readBytes(test::layerDir(whole) / io::kTilesetFile);

  // Two shards one after the other: the second finds the first's meshes.
  const config::TileJob sharded = tilesetJob("sharded");
  fs::remove_all(test::layerDir(sharded));
  pipeline::RunOptions options;
  options.shard_count = 2;
  for (int shard : {1, 2}) {
    options.shard = shard;
    ASSERT_EQ(pipeline::runTileJob(sharded, options).failed, 0);
  }
  EXPECT_EQ(test::readBytes(test::layerDir(sharded) / io::kTilesetFile), expected);

  config::TileJob mbtiles = tilesetJob("mbtiles");
  mbtiles.format = OutputFormat::kMbtiles;
  const fs::path file = fs::path(mbtiles.output_dir) / "layer.mbtiles";
  fs::remove(file);
  ASSERT_EQ(pipeline::runTileJob(mbtiles).failed, 0);
  const auto stored = io::MbtilesFile::openForReading(file.string());
  EXPECT_EQ(stored->tilesetDocument(io::kTilesetFile).value_or(""), expected);
  for (const auto& entry : fs::recursive_directory_iterator(test::layerDir(whole) / "tilesets")) {
    if (!entry.is_regular_file()) continue;
    const std::string path = fs::relative(entry.path(), test::layerDir(whole)).string();
    EXPECT_EQ(stored->tilesetDocument(path).value_or(""), test::readBytes(entry.path())) << path;
  }
}

// A tile whose mesh runs across the antimeridian, and a parent of tiles
// either side of it, is bounded by a box in its frame (3d-tiles-renderer
// makes a region with west > east a box round the other side of the globe,
// thousands of kilometres across); every volume still holds its meshes and its children's, and a
// union of regions either side of the antimeridian spans the gap between
// them, not the whole band of longitudes: the root's box is about as wide
// as the tiles under it. A DEM counted from 179.9 to 180.1 degrees, tiled
// on its own grid (tiles across 180) and geodetic (tiles either side).
TEST(Tileset, BoundsTilesAcrossTheAntimeridianWithBoxes) {
  const fs::path dem = test::acrossAntimeridianDem();
  struct Case {
    SchemeKind scheme;
    int min_zoom, max_zoom;
    double root_half_axis_m;  // at most: half the tiles' extent, and some
  };
  // The DEM is 14 km by 22 km; zoom-5 geodetic tiles are 5.6 degrees, 400 km at 50 N.
  for (const Case& c : {Case{SchemeKind::kNative, 0, 0, 20e3}, Case{SchemeKind::kGeodetic, 5, 8, 500e3}}) {
    const std::string name(wordOf(c.scheme));
    SCOPED_TRACE(name);
    config::TileJob job = test::tileJob(dem, "tileset/antimeridian_" + name, c.scheme, c.min_zoom, c.max_zoom);
    job.max_zoom_auto = c.scheme == SchemeKind::kNative;  // every level of the DEM's own pyramid
    job.tile_size = 32;
    job.tileset = true;
    job.backend = Backend::kCpu;
    fs::remove_all(test::layerDir(job));
    ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
    const fs::path layer = test::layerDir(job);
    const std::set<TileId> on_disk = test::meshesOnDisk(layer);
    ASSERT_FALSE(on_disk.empty());
    const int deepest = std::max_element(on_disk.begin(), on_disk.end())->z;

    test::TilesetWalk walk = folderWalk(layer, deepest);
    walk.run();
    for (const TileId& id : on_disk) EXPECT_EQ(walk.meshes_seen[id], 1) << id.str() << " is not in the tileset once";
    EXPECT_GE(walk.boxes, 1);
    const json root = readJson(layer / io::kTilesetFile).at("root");
    ASSERT_TRUE(root.at("boundingVolume").contains("box")) << "the root holds tiles either side of 180 degrees";
    const json& box = root.at("boundingVolume").at("box");
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const glm::dvec3 half(box.at(3 + 3 * axis), box.at(4 + 3 * axis), box.at(5 + 3 * axis));
      EXPECT_LT(glm::length(half), c.root_half_axis_m) << "axis " << axis;
    }
  }
}

// A 3 x 3 grid over the unit UV square, 100 m a side, flat at height 0.
mesh::TriangleMesh flatGrid() {
  mesh::TriangleMesh m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      m.position.emplace_back(float(c * 50 - 50), 0.0f, float(r * 50 - 50));
      m.normal.emplace_back(0.0f, 1.0f, 0.0f);
      m.tangent.emplace_back(1.0f, 0.0f, 0.0f, 1.0f);
      m.uv.emplace_back(float(c) / 2, float(r) / 2);
    }
  }
  m.indices = mesh::gridIndices(3, 3);
  return m;
}

TEST(Skirts, HangTheirDepthUnderTheBorderFacingOutWithTheEdgesFrame) {
  constexpr double kDepthM = 7.5;
  mesh::TriangleMesh m = flatGrid();
  const std::size_t vertices = m.position.size(), indices = m.indices.size();
  mesh::addSkirts(m, kDepthM);
  // The 8 border vertices get a copy each; the 8 border edges two triangles each.
  ASSERT_EQ(m.position.size(), vertices + 8);
  ASSERT_EQ(m.indices.size(), indices + 8 * 6);
  for (std::size_t k = vertices; k < m.position.size(); ++k) {
    // The copy's top: the border vertex with the same UV.
    std::size_t top = vertices;
    for (std::size_t t = 0; t < vertices; ++t) {
      if (m.uv[t] == m.uv[k]) top = t;
    }
    ASSERT_LT(top, vertices);
    EXPECT_NEAR(glm::distance(glm::dvec3(m.position[k]), glm::dvec3(m.position[top])), kDepthM, 1e-4);
    EXPECT_LT(m.position[k].y, m.position[top].y - kDepthM * 0.999);
    EXPECT_EQ(m.normal[k], m.normal[top]);
    EXPECT_EQ(m.tangent[k], m.tangent[top]);
  }
  for (std::size_t i = indices; i < m.indices.size(); i += 3) {
    const glm::dvec3 a(m.position[m.indices[i]]), b(m.position[m.indices[i + 1]]), c(m.position[m.indices[i + 2]]);
    const glm::dvec3 face = glm::cross(b - a, c - a);
    const glm::dvec3 centre = (a + b + c) / 3.0;
    // Outward: away from the tile's middle, in the horizontal plane.
    EXPECT_GT(glm::dot(face, glm::dvec3(centre.x, 0, centre.z)), 0) << "skirt triangle " << (i - indices) / 3;
  }
}

TEST(Skirts, LeaveMeshesWithoutBorderEdgesAlone) {
  mesh::TriangleMesh m = flatGrid();
  m.indices = {0, 4, 8};  // corner, middle, corner: no edge along the border
  const mesh::TriangleMesh before = m;
  mesh::addSkirts(m, 10);
  EXPECT_EQ(m.position.size(), before.position.size());
  EXPECT_EQ(m.indices, before.indices);
}

}  // namespace
}  // namespace terrabake

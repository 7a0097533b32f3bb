// A layer's 3D Tiles (docs/CONTRACT.md §8), judged from the files alone the
// way a 3D Tiles viewer reads them: every content URI resolves, each tile's
// region holds its children's and every point of its own mesh,
// geometricError falls strictly down the tree, and the transforms composed
// from the root place each mesh where its enu_to_ecef says. The pyramid is
// deep enough to continue in external tilesets. Skirts: walls of the stated
// depth under the tile's border, facing out, shaded like the edge above.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>

#include <cmath>
#include <fstream>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "io/mbtiles.hpp"
#include "io/tileset.hpp"
#include "layer_check.hpp"
#include "mesh/skirt.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;
using json = nlohmann::json;

// What the issue of transforms asks: composed down the tree, a tile lands
// within 1 mm of its mesh's own enu_to_ecef.
constexpr double kTransformToleranceM = 1e-3;
// Region bounds are written with 17 significant digits; float32 vertex
// positions round by under 1 mm on these tiles (a few km across), which is
// 1.6e-10 rad on the ground.
constexpr double kRegionToleranceRad = 1e-9;
constexpr double kRegionToleranceM = 2e-3;
// Zooms 8 to 14: seven levels, one more than a tileset file holds.
constexpr int kMinZoom = 8, kMaxZoom = 14;
static_assert(kMaxZoom - kMinZoom >= io::kTilesetLevelsPerFile);

json readJson(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

glm::dmat4 matrixOf(const json& values) {
  glm::dmat4 m(1.0);
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) m[c][r] = values.at(std::size_t(4 * c + r)).get<double>();
  }
  return m;
}

// 3D Tiles turns glTF content y-up to z-up before the tile's transform.
glm::dvec3 yUpToZUp(const glm::dvec3& p) { return {p.x, -p.z, p.y}; }

struct Region {
  double west, south, east, north, low, high;
};

Region regionOf(const json& tile) {
  const json& r = tile.at("boundingVolume").at("region");
  return {r.at(0), r.at(1), r.at(2), r.at(3), r.at(4), r.at(5)};
}

bool inside(const Region& outer, const Region& inner) {
  return inner.west >= outer.west - kRegionToleranceRad && inner.east <= outer.east + kRegionToleranceRad &&
         inner.south >= outer.south - kRegionToleranceRad && inner.north <= outer.north + kRegionToleranceRad &&
         inner.low >= outer.low - kRegionToleranceM && inner.high <= outer.high + kRegionToleranceM;
}

// Walks a tileset as a viewer does, checking each tile against its parent.
class TilesetWalk {
 public:
  explicit TilesetWalk(fs::path layer) : m_layer(std::move(layer)) {}

  void run() {
    const json doc = readJson(m_layer / io::kTilesetFile);
    EXPECT_EQ(doc.at("asset").at("version"), "1.1");
    const json& root = doc.at("root");
    EXPECT_GT(root.at("geometricError").get<double>(), 0) << "a root of error 0 never refines into its tiles";
    EXPECT_GE(doc.at("geometricError").get<double>(), root.at("geometricError").get<double>());
    visit(root, "", glm::dmat4(1.0), std::nullopt, 0);
  }

  std::map<TileId, int> meshes_seen;  // how often each .glb is some tile's content
  int external_tilesets = 0;
  int deepest_leaf_errors_nonzero = 0;

 private:
  struct Parent {
    Region region;
    double error;
  };

  void visit(const json& tile, const fs::path& doc_dir, const glm::dmat4& parent_world,
             const std::optional<Parent>& parent, int depth) {
    ASSERT_LT(depth, 64) << "the tree is deeper than any pyramid";
    const Region region = regionOf(tile);
    const double error = tile.at("geometricError").get<double>();
    EXPECT_LE(region.west, region.east);
    EXPECT_LE(region.south, region.north);
    EXPECT_LE(region.low, region.high);
    EXPECT_EQ(tile.value("refine", "REPLACE"), "REPLACE");
    if (parent) {
      EXPECT_TRUE(inside(parent->region, region)) << "a child's region leaves its parent's";
      EXPECT_LT(error, parent->error) << "geometricError must fall down the tree";
    }
    const glm::dmat4 world = tile.contains("transform") ? parent_world * matrixOf(tile["transform"]) : parent_world;

    if (tile.contains("content")) {
      const std::string uri = tile["content"].at("uri");
      const fs::path relative = (doc_dir / uri).lexically_normal();
      ASSERT_TRUE(fs::exists(m_layer / relative)) << uri << " from " << doc_dir << " does not resolve";
      if (relative.extension() == ".json") {
        // An external tileset: its root is this tile again, holding the rest.
        ++external_tilesets;
        EXPECT_FALSE(tile.contains("children")) << "a tile pointing to a tileset has no children of its own";
        const json doc = readJson(m_layer / relative);
        const json& root = doc.at("root");
        const Region same = regionOf(root);
        EXPECT_TRUE(inside(region, same) && inside(same, region));
        EXPECT_EQ(root.at("geometricError").get<double>(), error);
        const glm::dmat4 root_world = root.contains("transform") ? world * matrixOf(root["transform"]) : world;
        checkContent(root, relative.parent_path(), root_world, region);
        for (const json& child : root.value("children", json::array())) {
          visit(child, relative.parent_path(), root_world, Parent{region, error}, depth + 1);
        }
        return;
      }
      checkContent(tile, doc_dir, world, region);
    }
    for (const json& child : tile.value("children", json::array())) {
      visit(child, doc_dir, world, Parent{region, error}, depth + 1);
    }
  }

  // The tile's .glb lies inside its region, where its transform puts it.
  void checkContent(const json& tile, const fs::path& doc_dir, const glm::dmat4& world, const Region& region) {
    const fs::path relative = (doc_dir / tile.at("content").at("uri").get<std::string>()).lexically_normal();
    const TileId id{std::stoi(relative.parent_path().parent_path().string()),
                    std::stoi(relative.parent_path().filename().string()), std::stoi(relative.stem().string())};
    ++meshes_seen[id];
    const ts::GlbMesh mesh = ts::readGlb(m_layer / relative);
    if (id.z == kMaxZoom && tile.at("geometricError").get<double>() != 0) ++deepest_leaf_errors_nonzero;
    const glm::dmat4 own = matrixOf(json(mesh.enu_to_ecef));
    double worst_m = 0;
    Region seen{10, 10, -10, -10, 1e300, -1e300};
    for (const glm::dvec3& p : mesh.position) {
      const glm::dvec3 ecef = glm::dvec3(own * glm::dvec4(p, 1.0));
      worst_m = std::max(worst_m, glm::distance(glm::dvec3(world * glm::dvec4(yUpToZUp(p), 1.0)), ecef));
      double lat = 0, lon = 0, h = 0;
      GeographicLib::Geocentric::WGS84().Reverse(ecef.x, ecef.y, ecef.z, lat, lon, h);
      seen = {std::min(seen.west, lon * M_PI / 180), std::min(seen.south, lat * M_PI / 180),
              std::max(seen.east, lon * M_PI / 180), std::max(seen.north, lat * M_PI / 180),
              std::min(seen.low, h), std::max(seen.high, h)};
    }
    EXPECT_LT(worst_m, kTransformToleranceM) << relative << ": the composed transforms miss enu_to_ecef";
    EXPECT_TRUE(inside(region, seen)) << relative << ": a vertex lies outside the tile's region";
  }

  fs::path m_layer;
};

config::TileJob tilesetJob(const std::string& name) {
  config::TileJob job = test::tileJob(test::smallDem(), "tileset/" + name, SchemeKind::kWebMercator, kMinZoom, kMaxZoom);
  job.tile_size = 32;
  job.tileset = true;
  job.backend = Backend::kCpu;
  return job;
}

std::set<TileId> meshesOnDisk(const fs::path& layer) {
  std::set<TileId> ids;
  for (const auto& entry : fs::recursive_directory_iterator(layer)) {
    const fs::path& p = entry.path();
    if (p.extension() != ".glb" || p.stem().extension() == ".hires") continue;
    ids.insert({std::stoi(p.parent_path().parent_path().filename().string()),
                std::stoi(p.parent_path().filename().string()), std::stoi(p.stem().string())});
  }
  return ids;
}

TEST(Tileset, FollowsTheStructuralRulesOf3DTiles) {
  const config::TileJob job = tilesetJob("structure");
  fs::remove_all(test::layerDir(job));
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const fs::path layer = test::layerDir(job);

  TilesetWalk walk(layer);
  walk.run();
  EXPECT_GT(walk.external_tilesets, 0) << "seven levels continue in external tilesets";
  EXPECT_EQ(walk.deepest_leaf_errors_nonzero, 0) << "the deepest zoom's tiles are the terrain itself";
  const std::set<TileId> on_disk = meshesOnDisk(layer);
  ASSERT_FALSE(on_disk.empty());
  for (const TileId& id : on_disk) EXPECT_EQ(walk.meshes_seen[id], 1) << id.str() << " is not in the tileset once";
  EXPECT_EQ(walk.meshes_seen.size(), on_disk.size());

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

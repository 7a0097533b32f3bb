#pragma once
// Walks a layer's 3D Tiles tileset (docs/CONTRACT.md §8) as a viewer does,
// through whatever serves the layer's files (its folder, a server): every
// content URI resolves, each tile's region holds its children's and every
// point of its own mesh, geometricError falls strictly down the tree (and
// holds its mesh's distance and texel size), a file holds six levels, and
// the transforms composed from the root place each mesh where its
// enu_to_ecef says. Shared by tileset_test and server_tileset_test.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>

#include "core/types.hpp"
#include "io/tileset.hpp"
#include "support/glb_reader.hpp"
#include "test_helpers.hpp"

namespace terrabake::test {

// What the issue of transforms asks: composed down the tree, a tile lands
// within 1 mm of its mesh's own enu_to_ecef.
constexpr double kTransformToleranceM = 1e-3;
// Region bounds are written with 17 significant digits; float32 vertex
// positions round by under 1 mm on these tiles (a few km across), which is
// 1.6e-10 rad on the ground.
constexpr double kRegionToleranceRad = 1e-9;
constexpr double kRegionToleranceM = 2e-3;
// A texel's ground size from a mesh's span of longitudes, on a sphere of the
// earth's mean radius: the mesh's vertices reach the tile's edges, and the
// ellipsoid's radius of curvature differs from the mean by under 0.5 %.
constexpr double kMeanEarthRadiusM = 6371008.8;
constexpr double kTexelSizeRelative = 0.005;

// The tiles whose low-poly .glb lies in a layer folder ({z}/{x}/{y}.glb).
inline std::set<TileId> meshesOnDisk(const std::filesystem::path& layer) {
  std::set<TileId> ids;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(layer)) {
    const std::filesystem::path& p = entry.path();
    if (p.extension() != ".glb" || p.stem().extension() == ".hires") continue;
    ids.insert({std::stoi(p.parent_path().parent_path().filename().string()),
                std::stoi(p.parent_path().filename().string()), std::stoi(p.stem().string())});
  }
  return ids;
}

struct TilesetRegion {
  double west, south, east, north, low, high;
};

inline TilesetRegion regionOf(const nlohmann::json& tile) {
  const nlohmann::json& r = tile.at("boundingVolume").at("region");
  return {r.at(0), r.at(1), r.at(2), r.at(3), r.at(4), r.at(5)};
}

inline bool inside(const TilesetRegion& outer, const TilesetRegion& inner) {
  return inner.west >= outer.west - kRegionToleranceRad && inner.east <= outer.east + kRegionToleranceRad &&
         inner.south >= outer.south - kRegionToleranceRad && inner.north <= outer.north + kRegionToleranceRad &&
         inner.low >= outer.low - kRegionToleranceM && inner.high <= outer.high + kRegionToleranceM;
}

inline glm::dmat4 matrixOf(const nlohmann::json& values) {
  glm::dmat4 m(1.0);
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) m[c][r] = values.at(std::size_t(4 * c + r)).get<double>();
  }
  return m;
}

// 3D Tiles turns glTF content y-up to z-up before the tile's transform.
inline glm::dvec3 yUpToZUp(const glm::dvec3& p) { return {p.x, -p.z, p.y}; }

class TilesetWalk {
 public:
  // A file of the layer by its path under the layer ("tileset.json",
  // "13/4/5.glb"); nullopt when it does not resolve. A .glb fetched is then
  // read from the layer folder `layer`.
  using Fetch = std::function<std::optional<std::string>(const std::string& path)>;

  TilesetWalk(std::filesystem::path layer, int deepest_zoom, Fetch fetch)
      : m_layer(std::move(layer)), m_deepest_zoom(deepest_zoom), m_fetch(std::move(fetch)) {}

  void run() {
    const std::optional<std::string> text = m_fetch(io::kTilesetFile);
    ASSERT_TRUE(text) << "no " << io::kTilesetFile;
    const nlohmann::json doc = nlohmann::json::parse(*text);
    EXPECT_EQ(doc.at("asset").at("version"), "1.1");
    const nlohmann::json& root = doc.at("root");
    EXPECT_GT(root.at("geometricError").get<double>(), 0) << "a root of error 0 never refines into its tiles";
    EXPECT_GE(doc.at("geometricError").get<double>(), root.at("geometricError").get<double>());
    HeightSpan all;
    visit(root, "", glm::dmat4(1.0), std::nullopt, 0, 0, all);
  }

  std::map<TileId, int> meshes_seen;  // how often each .glb is some tile's content
  int external_tilesets = 0;
  int deepest_leaf_errors_nonzero = 0;
  // The largest amount by which the lowest point of a tile's mesh and its
  // descendants' lies above the tile's region's floor, and their highest
  // point below the ceiling: how loose the regions are.
  double loosest_floor_m = 0;
  double loosest_ceiling_m = 0;

 private:
  struct Parent {
    TilesetRegion region;
    double error;
  };

  // The heights of the meshes under a tile, itself included.
  struct HeightSpan {
    double low = 1e300, high = -1e300;
    void add(const HeightSpan& other) {
      low = std::min(low, other.low);
      high = std::max(high, other.high);
    }
  };

  // `depth` counts levels from the root, `file_level` the tiles with a mesh
  // above this one in the file that holds it.
  void visit(const nlohmann::json& tile, const std::filesystem::path& doc_dir, const glm::dmat4& parent_world,
             const std::optional<Parent>& parent, int depth, int file_level, HeightSpan& heights_above) {
    ASSERT_LT(depth, 64) << "the tree is deeper than any pyramid";
    const TilesetRegion region = regionOf(tile);
    HeightSpan heights;
    // Runs on every way out of this tile, the assertions' early returns included.
    struct Fold {
      const TilesetRegion& region;
      HeightSpan& heights;
      HeightSpan& above;
      TilesetWalk& walk;
      ~Fold() {
        if (heights.low > heights.high) return;  // no mesh under this tile
        walk.loosest_floor_m = std::max(walk.loosest_floor_m, heights.low - region.low);
        walk.loosest_ceiling_m = std::max(walk.loosest_ceiling_m, region.high - heights.high);
        above.add(heights);
      }
    } fold{region, heights, heights_above, *this};
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
      const std::filesystem::path relative = (doc_dir / uri).lexically_normal();
      if (relative.extension() == ".json") {
        const std::optional<std::string> fetched = m_fetch(relative.generic_string());
        ASSERT_TRUE(fetched) << uri << " from " << doc_dir << " does not resolve";
        // An external tileset: its root is this tile again, holding the rest.
        ++external_tilesets;
        EXPECT_FALSE(tile.contains("children")) << "a tile pointing to a tileset has no children of its own";
        const nlohmann::json doc = nlohmann::json::parse(*fetched);
        const nlohmann::json& root = doc.at("root");
        const TilesetRegion same = regionOf(root);
        EXPECT_TRUE(inside(region, same) && inside(same, region));
        EXPECT_EQ(root.at("geometricError").get<double>(), error);
        EXPECT_EQ(file_level, io::kTilesetLevelsPerFile) << uri << ": an external tileset not after a file's levels";
        EXPECT_FALSE(root.contains("transform")) << uri << ": its root is placed by the referring tile alone";
        const std::string mesh_uri = root.at("content").at("uri");
        const std::filesystem::path mesh_path = (relative.parent_path() / mesh_uri).lexically_normal();
        EXPECT_EQ(relative, std::filesystem::path("tilesets") / mesh_path.parent_path() /
                                (mesh_path.stem().string() + ".json"))
            << "an external tileset is tilesets/{z}/{x}/{y}.json of its root's tile";
        checkContent(root, relative.parent_path(), world, region, heights);
        for (const nlohmann::json& child : root.value("children", nlohmann::json::array())) {
          visit(child, relative.parent_path(), world, Parent{region, error}, depth + 1, 1, heights);
        }
        return;
      }
      EXPECT_LT(file_level, io::kTilesetLevelsPerFile) << uri << ": a file holds at most that many levels";
      checkContent(tile, doc_dir, world, region, heights);
    }
    const int below = file_level + (tile.contains("content") ? 1 : 0);
    for (const nlohmann::json& child : tile.value("children", nlohmann::json::array())) {
      visit(child, doc_dir, world, Parent{region, error}, depth + 1, below, heights);
    }
  }

  // The tile's .glb lies inside its region, where its transform puts it.
  void checkContent(const nlohmann::json& tile, const std::filesystem::path& doc_dir, const glm::dmat4& world,
                    const TilesetRegion& region, HeightSpan& heights) {
    const std::filesystem::path relative =
        (doc_dir / tile.at("content").at("uri").get<std::string>()).lexically_normal();
    ASSERT_TRUE(m_fetch(relative.generic_string())) << relative << " from " << doc_dir << " does not resolve";
    const TileId id{std::stoi(relative.parent_path().parent_path().string()),
                    std::stoi(relative.parent_path().filename().string()), std::stoi(relative.stem().string())};
    ++meshes_seen[id];
    const test_support::GlbMesh mesh = test_support::readGlb(m_layer / relative);
    if (id.z == m_deepest_zoom && tile.at("geometricError").get<double>() != 0) ++deepest_leaf_errors_nonzero;
    const glm::dmat4 own = matrixOf(nlohmann::json(mesh.enu_to_ecef));
    double worst_m = 0;
    TilesetRegion seen{10, 10, -10, -10, 1e300, -1e300};
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
    heights.add({seen.low, seen.high});
    // A tile with children states at least the mesh's own distance to the
    // samples and the ground size of its widest texel: the mesh's span of
    // longitudes where it lies nearest the equator, over the texels a side.
    if (!tile.contains("children") || tile.at("children").empty()) return;
    const double error = tile.at("geometricError").get<double>();
    const double mesh_error_m = mesh.json.at("asset").at("extras").at("terrabake").at("max_error_m").get<double>();
    const double widest_cos = seen.south <= 0 && seen.north >= 0
                                  ? 1.0
                                  : std::max(std::cos(seen.south), std::cos(seen.north));
    const double texel_m = (seen.east - seen.west) * widest_cos * kMeanEarthRadiusM / pngWidth(m_layer / relative);
    EXPECT_GE(error, mesh_error_m) << relative << ": geometricError under the mesh's own distance";
    EXPECT_GE(error, texel_m * (1 - kTexelSizeRelative)) << relative << ": geometricError under a texel's size";
  }

  // The width of the normal map beside a .glb, from its PNG header.
  static int pngWidth(std::filesystem::path glb) {
    const std::string bytes = readBytes(glb.replace_extension(".png"));
    EXPECT_GE(bytes.size(), 24u) << glb;
    if (bytes.size() < 24) return 1;
    int width = 0;
    for (int k = 16; k < 20; ++k) width = width * 256 + static_cast<unsigned char>(bytes[std::size_t(k)]);
    return width;
  }

  std::filesystem::path m_layer;
  int m_deepest_zoom;
  Fetch m_fetch;
};

}  // namespace terrabake::test

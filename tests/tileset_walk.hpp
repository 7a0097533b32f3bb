#pragma once
// Walks a layer's 3D Tiles tileset (docs/CONTRACT.md §8) as a viewer does,
// through whatever serves the layer's files (its folder, a server): every
// content URI resolves, each tile's bounding volume (a region, or a box
// across the antimeridian) holds every point of its own mesh and of those
// below it, a region its children's regions, geometricError falls strictly down the tree (and
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
#include "support/analytic_terrain.hpp"
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
// A float32 coordinate rounds by half a step, 2^-24 of its size; a vertex,
// by the length of three such (√3 times) of its largest coordinate, twice
// over for the sums that place it (as layer_check.hpp's kFloat32EdgeGapShare).
// Native tiles hundreds of kilometres across move by centimetres.
constexpr double kFloat32PlacementShare = 2 * 1.7320508075688772 / 16777216.0;
// The WGS84 meridian's smallest radius of curvature, a(1 - e^2): metres to radians of latitude, at most.
constexpr double kMinCurvatureRadiusM = 6335439.327;
// A texel's ground size from a mesh's span of longitudes, on a sphere of the
// earth's mean radius: the mesh's vertices reach the tile's edges, and the
// ellipsoid's radius of curvature differs from the mean by under 0.5 %.
constexpr double kMeanEarthRadiusM = 6371008.8;
constexpr double kTexelSizeRelative = 0.005;

// Hills on a DEM counted from 179.9 to 180.1 degrees (200 x 200 pixels of
// 0.001 degrees, 49.9 to 50.1 N): tiled on its own grid, tiles and their
// parents run across the antimeridian.
inline std::filesystem::path acrossAntimeridianDem() {
  return sharedFixture("tileset_across_antimeridian.tif", [](const std::filesystem::path& path) {
    test_support::writeFloatDem(path, 4326, {179.9, 0.001, 0, 50.1, 0, -0.001}, 200, 200, [](double lon, double lat) {
      return 600 + 250 * std::sin(lon * 2 * M_PI / 0.06) * std::cos(lat * 2 * M_PI / 0.045);
    });
  });
}

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
  double west, south, east, north, low, high;  // west > east across the antimeridian
};

// How far east `to` lies of `from`: in [0, 2π), and 2π from -π to π.
inline double eastwardRad(double from, double to) {
  const double d = to - from;
  return d < 0 ? d + 2 * M_PI : d;
}

// Whether longitude `lon` lies in [west, east], the way east from west,
// within `tolerance_rad`.
inline bool withinLongitudes(double west, double east, double lon, double tolerance_rad) {
  const double offset = eastwardRad(west, lon);
  return offset <= eastwardRad(west, east) + tolerance_rad || offset >= 2 * M_PI - tolerance_rad;
}

// A tile's boundingVolume: a region, or a box in the tile's frame.
struct TileVolume {
  std::optional<TilesetRegion> region;
  glm::dmat4 box_to_ecef{1.0};  // the cube [-1, 1]^3 onto the box, in ECEF

  // Whether `ecef` lies inside, within `tolerance_m` on the ground.
  bool holds(const glm::dvec3& ecef, double tolerance_m = kRegionToleranceM) const {
    if (!region) {
      const glm::dvec3 cube(glm::inverse(box_to_ecef) * glm::dvec4(ecef, 1.0));
      for (int k = 0; k < 3; ++k) {
        const double half_m = glm::length(glm::dvec3(box_to_ecef[k]));
        if ((std::abs(cube[k]) - 1) * half_m > tolerance_m) return false;
      }
      return true;
    }
    double lat = 0, lon = 0, h = 0;
    GeographicLib::Geocentric::WGS84().Reverse(ecef.x, ecef.y, ecef.z, lat, lon, h);
    const TilesetRegion& r = *region;
    // Near a pole a float32 vertex's millimetres span many radians of longitude.
    const double from_axis_m = std::hypot(ecef.x, ecef.y);
    const double lon_tolerance_rad = std::max(kRegionToleranceRad, tolerance_m / from_axis_m);
    const double lat_tolerance_rad = std::max(kRegionToleranceRad, tolerance_m / kMinCurvatureRadiusM);
    return withinLongitudes(r.west, r.east, lon * M_PI / 180, lon_tolerance_rad) &&
           lat * M_PI / 180 >= r.south - lat_tolerance_rad && lat * M_PI / 180 <= r.north + lat_tolerance_rad &&
           h >= r.low - tolerance_m && h <= r.high + tolerance_m;
  }

  // A region's points on a grid of its longitudes and latitudes, at its
  // lowest and highest heights.
  std::vector<glm::dvec3> outline() const {
    std::vector<glm::dvec3> points;
    constexpr int kSteps = 8;
    const TilesetRegion& r = *region;
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; j <= kSteps; ++j) {
        for (const double h : {r.low, r.high}) {
          const double lon = r.west + eastwardRad(r.west, r.east) * i / kSteps;
          const double lat = r.south + (r.north - r.south) * j / kSteps;
          glm::dvec3 p;
          GeographicLib::Geocentric::WGS84().Forward(lat * 180 / M_PI, lon * 180 / M_PI, h, p.x, p.y, p.z);
          points.push_back(p);
        }
      }
    }
    return points;
  }
};

// The tile's boundingVolume, its box in the frame `world` places the tile in.
inline TileVolume volumeOf(const nlohmann::json& tile, const glm::dmat4& world) {
  const nlohmann::json& volume = tile.at("boundingVolume");
  TileVolume v;
  if (volume.contains("region")) {
    const nlohmann::json& r = volume.at("region");
    v.region = TilesetRegion{r.at(0), r.at(1), r.at(2), r.at(3), r.at(4), r.at(5)};
    return v;
  }
  const nlohmann::json& b = volume.at("box");
  glm::dmat4 box(1.0);
  for (int c = 0; c < 4; ++c) {
    const std::size_t from = c == 3 ? 0 : std::size_t(3 * (c + 1));  // the half axes, then the centre
    box[c] = glm::dvec4(b.at(from).get<double>(), b.at(from + 1).get<double>(), b.at(from + 2).get<double>(), c == 3);
  }
  v.box_to_ecef = world * box;
  return v;
}

// Whether every point of region `inner` lies in `outer`. (A box around a
// region reaches past it, so the test of a box is that of the meshes under it.)
inline bool inside(const TileVolume& outer, const TileVolume& inner) {
  const std::vector<glm::dvec3> points = inner.outline();
  return std::all_of(points.begin(), points.end(), [&](const glm::dvec3& p) { return outer.holds(p); });
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
  // Contents that did not resolve (a planned tile that bakes empty), a
  // failure unless allowed.
  std::set<TileId> unresolved;
  bool unresolved_allowed = false;
  int external_tilesets = 0;
  int boxes = 0;  // tiles bounded by a box rather than a region
  int deepest_leaf_errors_nonzero = 0;
  // The largest amount by which the lowest point of a tile's mesh and its
  // descendants' lies above the tile's region's floor, and their highest
  // point below the ceiling: how loose the regions are.
  double loosest_floor_m = 0;
  double loosest_ceiling_m = 0;

 private:
  struct Parent {
    TileVolume volume;
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
    const glm::dmat4 world = tile.contains("transform") ? parent_world * matrixOf(tile["transform"]) : parent_world;
    const TileVolume volume = volumeOf(tile, world);
    HeightSpan heights;
    // Runs on every way out of this tile, the assertions' early returns included.
    struct Fold {
      const TileVolume& volume;
      HeightSpan& heights;
      HeightSpan& above;
      TilesetWalk& walk;
      ~Fold() {
        walk.m_path.pop_back();
        if (heights.low > heights.high) return;  // no mesh under this tile
        if (volume.region) {
          walk.loosest_floor_m = std::max(walk.loosest_floor_m, heights.low - volume.region->low);
          walk.loosest_ceiling_m = std::max(walk.loosest_ceiling_m, volume.region->high - heights.high);
        }
        above.add(heights);
      }
    } fold{volume, heights, heights_above, *this};
    m_path.push_back(volume);
    const double error = tile.at("geometricError").get<double>();
    if (volume.region) {
      EXPECT_LE(volume.region->south, volume.region->north);
      EXPECT_LE(volume.region->low, volume.region->high);
      for (const double lon : {volume.region->west, volume.region->east}) {
        EXPECT_LE(std::abs(lon), M_PI) << "3D Tiles' longitudes lie in [-π, π]";
      }
    } else {
      ++boxes;
    }
    EXPECT_EQ(tile.value("refine", "REPLACE"), "REPLACE");
    if (parent) {
      if (volume.region) {
        EXPECT_TRUE(inside(parent->volume, volume)) << "a child's region leaves its parent's volume";
      }
      EXPECT_LT(error, parent->error) << "geometricError must fall down the tree";
    }

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
        EXPECT_EQ(root.at("boundingVolume"), tile.at("boundingVolume"));
        EXPECT_EQ(root.at("geometricError").get<double>(), error);
        EXPECT_EQ(file_level, io::kTilesetLevelsPerFile) << uri << ": an external tileset not after a file's levels";
        EXPECT_FALSE(root.contains("transform")) << uri << ": its root is placed by the referring tile alone";
        const std::string mesh_uri = root.at("content").at("uri");
        const std::filesystem::path mesh_path = (relative.parent_path() / mesh_uri).lexically_normal();
        EXPECT_EQ(relative, std::filesystem::path("tilesets") / mesh_path.parent_path() /
                                (mesh_path.stem().string() + ".json"))
            << "an external tileset is tilesets/{z}/{x}/{y}.json of its root's tile";
        checkContent(root, relative.parent_path(), world, heights);
        for (const nlohmann::json& child : root.value("children", nlohmann::json::array())) {
          visit(child, relative.parent_path(), world, Parent{volume, error}, depth + 1, 1, heights);
        }
        return;
      }
      EXPECT_LT(file_level, io::kTilesetLevelsPerFile) << uri << ": a file holds at most that many levels";
      checkContent(tile, doc_dir, world, heights);
    }
    const int below = file_level + (tile.contains("content") ? 1 : 0);
    for (const nlohmann::json& child : tile.value("children", nlohmann::json::array())) {
      visit(child, doc_dir, world, Parent{volume, error}, depth + 1, below, heights);
    }
  }

  // The tile's .glb lies inside its bounding volume and those above it, where its transform puts it.
  void checkContent(const nlohmann::json& tile, const std::filesystem::path& doc_dir, const glm::dmat4& world,
                    HeightSpan& heights) {
    const std::filesystem::path relative =
        (doc_dir / tile.at("content").at("uri").get<std::string>()).lexically_normal();
    const TileId id{std::stoi(relative.parent_path().parent_path().string()),
                    std::stoi(relative.parent_path().filename().string()), std::stoi(relative.stem().string())};
    if (!m_fetch(relative.generic_string())) {
      unresolved.insert(id);
      EXPECT_TRUE(unresolved_allowed) << relative << " from " << doc_dir << " does not resolve";
      return;
    }
    ++meshes_seen[id];
    const test_support::GlbMesh mesh = test_support::readGlb(m_layer / relative);
    if (id.z == m_deepest_zoom && tile.at("geometricError").get<double>() != 0) ++deepest_leaf_errors_nonzero;
    const glm::dmat4 own = matrixOf(nlohmann::json(mesh.enu_to_ecef));
    double worst_m = 0;
    int outside = 0;
    // How far float32 may have moved a vertex from where it belongs.
    double largest_m = 0;
    for (const glm::dvec3& p : mesh.position) {
      largest_m = std::max({largest_m, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    }
    const double placement_m = std::max(kRegionToleranceM, kFloat32PlacementShare * largest_m);
    // Longitudes counted from the frame's origin's, so a mesh across the antimeridian spans no turn.
    const glm::dvec3 origin(own[3]);
    const double origin_lon = std::atan2(origin.y, origin.x);
    TilesetRegion seen{10, 10, -10, -10, 1e300, -1e300};
    for (const glm::dvec3& p : mesh.position) {
      const glm::dvec3 ecef = glm::dvec3(own * glm::dvec4(p, 1.0));
      worst_m = std::max(worst_m, glm::distance(glm::dvec3(world * glm::dvec4(yUpToZUp(p), 1.0)), ecef));
      for (const TileVolume& holder : m_path) outside += holder.holds(ecef, placement_m) ? 0 : 1;
      double lat = 0, lon = 0, h = 0;
      GeographicLib::Geocentric::WGS84().Reverse(ecef.x, ecef.y, ecef.z, lat, lon, h);
      const double from_origin = std::remainder(lon * M_PI / 180 - origin_lon, 2 * M_PI);
      seen = {std::min(seen.west, from_origin),
              std::min(seen.south, lat * M_PI / 180),
              std::max(seen.east, from_origin),
              std::max(seen.north, lat * M_PI / 180),
              std::min(seen.low, h),
              std::max(seen.high, h)};
    }
    EXPECT_LT(worst_m, kTransformToleranceM) << relative << ": the composed transforms miss enu_to_ecef";
    EXPECT_EQ(outside, 0) << relative << ": vertices lie outside the bounding volume of the tile or of a tile above";
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
  std::vector<TileVolume> m_path;  // the volumes of the tile being visited and those above it
};

}  // namespace terrabake::test

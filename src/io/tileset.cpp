#include "io/tileset.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>

#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "geo/region.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;

// A parent's geometricError is at least this much above its children's, so
// the order stays strict where their measured errors tie (a fixed
// low_poly.max_error_m gives every zoom the same bound).
constexpr double kParentErrorMargin = 1.01;
// The earth's mean radius, for a texel's ground size from its region.
constexpr double kMeanEarthRadiusM = 6371008.8;

struct Node {
  const TilesetTile* own = nullptr;  // null for the synthetic root
  std::vector<Node*> children;
  std::array<double, 6> region{};   // own and all descendants'
  double geometric_error = 0;
  glm::dmat4 world{1.0};            // ENU (z up) to ECEF
};

geo::Region regionOf(const std::array<double, 6>& r) { return {r[0], r[1], r[2], r[3], r[4], r[5]}; }

std::array<double, 6> unite(const std::array<double, 6>& a, const std::array<double, 6>& b) {
  const geo::Region r = geo::unite(regionOf(a), regionOf(b));
  return {r.west, r.south, r.east, r.north, r.min_height_m, r.max_height_m};
}

// The longer side of a region on the ground, in metres.
double regionSizeM(const std::array<double, 6>& region) {
  const double width = geo::eastwardRad(region[0], region[2]);
  const double widest_cos = region[1] <= 0 && region[3] >= 0 ? 1.0 : std::max(std::cos(region[1]), std::cos(region[3]));
  return std::max(width * widest_cos, region[3] - region[1]) * kMeanEarthRadiusM;
}

// The ground size of the tile's largest texel: its region's width at the
// latitude nearest the equator, or its height, over the tile size.
double texelSizeM(const std::array<double, 6>& region, int tile_size) { return regionSizeM(region) / tile_size; }

// ENU (3D Tiles' z-up) to ECEF, from the mesh's glTF-axis (y-up) matrix:
// 3D Tiles turns glTF content by (x, y, z) -> (x, -z, y) before the tile's
// transform, so that transform is enu_to_ecef with the turn undone.
glm::dmat4 enuToEcef(const std::array<double, 16>& gltf_to_ecef) {
  glm::dmat4 gltf(1.0);
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) gltf[c][r] = gltf_to_ecef[std::size_t(4 * c + r)];
  }
  glm::dmat4 unturn(0.0);  // z-up to y-up: (x, y, z) -> (x, z, -y)
  unturn[0][0] = 1;
  unturn[1][2] = -1;
  unturn[2][1] = 1;
  unturn[3][3] = 1;
  return gltf * unturn;
}

// The region, or where it runs across the antimeridian (west > east), a box
// around it in the tile's frame (`world`): 3d-tiles-renderer builds its box
// for such a region from the middle of its two longitudes, round the other
// side of the globe, thousands of kilometres across, and so never culls the
// tile or lets its error fall with distance. Every viewer reads the box alike.
Json boundingVolumeJson(const std::array<double, 6>& region, const glm::dmat4& world) {
  if (region[0] <= region[2]) return {{"region", region}};
  const geo::Box box = geo::boxAroundRegion(regionOf(region), world);
  Json values = Json::array();
  for (const glm::dvec3& v : {box.centre, box.half_axes[0], box.half_axes[1], box.half_axes[2]}) {
    values.insert(values.end(), {v.x, v.y, v.z});
  }
  return {{"box", values}};
}

Json matrixJson(const glm::dmat4& m) {
  Json values = Json::array();
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) values.push_back(m[c][r]);
  }
  return values;
}

// Relative URI from a document at `from` (a path under the layer folder) to `to`.
std::string relativeUri(const std::string& from, const std::string& to) {
  std::string up;
  for (char c : from) {
    if (c == '/') up += "../";
  }
  return up + to;
}

class Writer {
 public:
  explicit Writer(int min_zoom) : m_min_zoom(min_zoom) {}

  // Writes the document at `path` whose root is `root`, and those it points
  // to. A document's root has no transform (its tiles compose with the tile
  // that points to the document); a synthetic root is none of the layer's
  // tiles and holds the top zoom's as children.
  void writeDocument(const std::string& path, const Node& root, bool synthetic) {
    TilesetDocument doc{path, {}};
    const std::size_t index = m_docs.size();
    m_docs.push_back(doc);
    Json tile = tileJson(path, root, glm::dmat4(1.0), /*document_root=*/!synthetic);
    const Json tileset = {{"asset", {{"version", "1.1"}, {"generator", "terrabake"}}},
                          {"geometricError", root.geometric_error},
                          {"root", tile}};
    m_docs[index].json = tileset.dump(1) + "\n";
  }

  std::vector<TilesetDocument> take() { return std::move(m_docs); }

 private:
  // A tile of the document at `doc_path`. A tile that starts a new file is
  // written here as a reference to it, unless it is that file's root.
  Json tileJson(const std::string& doc_path, const Node& node, const glm::dmat4& parent_world, bool document_root) {
    Json tile = {{"boundingVolume", boundingVolumeJson(node.region, node.world)},
                 {"geometricError", node.geometric_error},
                 {"refine", "REPLACE"}};
    if (!node.own) {
      Json children = Json::array();
      for (const Node* child : node.children) children.push_back(tileJson(doc_path, *child, node.world, false));
      tile["children"] = children;
      return tile;
    }
    const TileId& id = node.own->tile;
    const bool starts_file = (id.z - m_min_zoom) % kTilesetLevelsPerFile == 0 && id.z != m_min_zoom;
    if (starts_file && !document_root) {
      // The external file's root has no transform: its tiles compose with this one's.
      tile["transform"] = matrixJson(glm::inverse(parent_world) * node.world);
      const std::string path = externalTilesetPath(id);
      tile["content"] = {{"uri", relativeUri(doc_path, path)}};
      writeDocument(path, node, false);
      return tile;
    }
    if (!document_root) tile["transform"] = matrixJson(glm::inverse(parent_world) * node.world);
    tile["content"] = {{"uri", relativeUri(doc_path, relativeTilePath(id, TileFormat::kGlb))}};
    if (!node.children.empty()) {
      Json children = Json::array();
      for (const Node* child : node.children) children.push_back(tileJson(doc_path, *child, node.world, false));
      tile["children"] = children;
    }
    return tile;
  }

  int m_min_zoom;
  std::vector<TilesetDocument> m_docs;
};

// How far the tile's own mesh and normal map are from the full-resolution
// terrain: the mesh's distance to its samples, or a texel, the larger.
double ownError(const TilesetTile& tile, int tile_size) {
  return std::max(tile.placement.max_error_m, texelSizeM(tile.placement.region, tile_size));
}

// Regions and errors from the leaves up; the root's error is set by the caller.
void summarise(Node& node, int tile_size) {
  double below = 0;
  for (Node* child : node.children) {
    summarise(*child, tile_size);
    const bool first_region = !node.own && child == node.children.front();
    node.region = first_region ? child->region : unite(node.region, child->region);
    below = std::max(below, child->geometric_error);
  }
  if (node.own) node.geometric_error = node.children.empty() ? 0 : std::max(ownError(*node.own, tile_size), kParentErrorMargin * below);
}

}  // namespace

std::string externalTilesetPath(const TileId& tile) {
  return "tilesets/" + std::to_string(tile.z) + "/" + std::to_string(tile.x) + "/" + std::to_string(tile.y) + ".json";
}

std::vector<TilesetDocument> buildTileset(const std::vector<TilesetTile>& tiles, int tile_size) {
  if (tiles.empty()) throw std::invalid_argument("buildTileset: no tiles");
  std::map<TileId, Node> nodes;
  for (const TilesetTile& t : tiles) {
    Node node;
    node.own = &t;
    node.region = t.placement.region;
    node.world = enuToEcef(t.placement.enu_to_ecef);
    if (!nodes.emplace(t.tile, node).second) throw std::invalid_argument("buildTileset: tile " + t.tile.str() + " twice");
  }
  const int min_zoom = nodes.begin()->first.z;  // TileId orders by zoom first
  Node root;
  for (auto& [id, node] : nodes) {  // zoom by zoom, so children are listed in a stable order
    const auto parent = id.z > min_zoom ? nodes.find(TileId{id.z - 1, id.x / 2, id.y / 2}) : nodes.end();
    (parent != nodes.end() ? parent->second : root).children.push_back(&node);
  }
  summarise(root, tile_size);
  // The root has no content: drawn instead of its children it would show
  // nothing, an error as large as the layer itself, so viewers refine it
  // from any distance at which the layer covers a pixel.
  double top_error = 0;
  for (const Node* top : root.children) {
    top_error = std::max({top_error, top->geometric_error, ownError(*top->own, tile_size)});
  }
  root.geometric_error = std::max(kParentErrorMargin * top_error, regionSizeM(root.region));

  Writer writer(min_zoom);
  writer.writeDocument(kTilesetFile, root, true);
  return writer.take();
}

}  // namespace terrabake::io

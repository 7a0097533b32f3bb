// Where the DEM ends inside a tile (docs/CONTRACT.md §3): texels with data are
// baked as accurately next to the edge as far from it, and beyond it the
// surface runs on without a step in height or normal (nodata.surface:
// continue), or nothing is drawn (cut).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

namespace ts = test_support;

// UTM zone 33, 2.5 degrees east of its central meridian: the DEM's grid turns
// about 2 degrees against Web Mercator's north, so its edges cross the texel
// rows and columns in a staircase, as most DEM edges do.
constexpr double kCentreLon = 17.5, kCentreLat = 60.0;
constexpr int kDemPixels = 256;
constexpr double kPixelM = 30.0;
// Two zooms, the two ways a DEM is read. At zoom 12, texels of 19 m at 60
// degrees north, the cubic kernel interpolates the 30 m pixels, and the DEM
// (7.7 km) ends inside tiles of 4.9 km on all four sides; at zoom 11, texels
// of 38 m average 1.3 pixels each, and it ends inside tiles of 9.8 km.
constexpr int kInterpolatedZoom = 12;
constexpr int kAveragedZoom = 11;

// The band the accuracy promise is judged in, and where "inside" starts for
// the steps it is compared with.
constexpr double kEdgeBandTexels = 3;

// 16 bits, so that quantisation does not hide the bake. The bounds of
// accuracy_test (docs/CONTRACT.md §4) are 0.05 and 0.1 degrees (mean, 99th
// percentile). Texels within three texels of the edge measure 0.005 and 0.025
// at zoom 12 (inside: 0.002 and 0.004; GDAL's kernel alone there, bilinear
// and then flat, with central differences into the fill, gave 2.8 and 18),
// 0.015 and 0.032 at zoom 11 (inside: 0.013 and 0.022; the footprint mean of
// the part on data gave 0.9 and 9.4).
constexpr double kMaxEdgeMeanDeg = 0.02;
constexpr double kMaxEdgeP99Deg = 0.05;

// A carried-on surface is as smooth as the data's own: across the edge, no
// decoded normal turns more than twice as far between neighbouring texels as
// it does anywhere inside (measured 1.0 times at zoom 12, 0.94 at zoom 11),
// and no height steps further than the terrain's own largest step.
constexpr double kMaxAcrossToInsideNormalStep = 2;
// Further out the continuation fades into the backdrop over max_fill_px
// texels: it bends the data's slope, up to 30 degrees here, back to the
// backdrop's, which takes up to 3.2 times the terrain's own sharpest bend
// between neighbouring texels. A wall or a lip (what the fill did before)
// turns normals by tens of degrees.
constexpr double kMaxFadeToInsideNormalStep = 4;

std::filesystem::path edgeDem() {
  return test::sharedFixture("edge_utm33_256.tif", [](const auto& path) {
    ts::writeUtmDem(path, kCentreLon, kCentreLat, kPixelM, kDemPixels, kDemPixels);
  });
}

using test::Stats;
using test::summarise;

void print(const char* what, const Stats& s) {
  std::printf("%-44s %7zu  mean %8.4f  p99 %8.4f  max %8.4f\n", what, s.count, s.mean, s.p99, s.max);
}

// Where a point lies against the DEM, found with GDAL on the DEM's pixel grid:
// inside it or not, and how many texels from its edge.
struct Place {
  bool has_data = false;
  double edge_texels = 0;
};

// GDAL's transformer is interpolated on a lattice: within this much of the
// DEM's edge a texel centre may fall on either side.
constexpr double kEdgeAmbiguityTexels = 1e-3;
// A texel centre this near a triangle's edge counts as on it: float32 UVs
// round by 1e-5 texels in these tiles, and the contract counts the edge in.
constexpr double kOnTriangleEdgeTexels = 1e-4;

// A layer of the edge DEM read back, every texel placed against the DEM.
class EdgeLayer {
 public:
  struct Tile {
    test::DecodedTile decoded;
    ts::GlbMesh high;
    std::vector<Place> texel;  // row-major
    int size() const { return decoded.png.width; }
    const Place& at(int i, int j) const { return texel[std::size_t(j) * size() + i]; }
    // Height of the sample at texel (i, j)'s centre: high-res vertex (i, j),
    // in the tile's frame (+Y up).
    double height(int i, int j) const { return high.position[std::size_t(j) * (size() + 1) + i].y; }
  };

  explicit EdgeLayer(const config::TileJob& job) : m_layer(test::layerDir(job)), m_geometry(edgeDem()) {
    const auto& layer = m_layer;
    const int zoom = job.min_zoom;
    for (const auto& column : std::filesystem::directory_iterator(layer / std::to_string(zoom))) {
      const int x = std::stoi(column.path().filename().string());
      for (const auto& file : std::filesystem::directory_iterator(column.path())) {
        if (file.path().extension() != ".png" || file.path().stem().has_extension()) continue;  // not {y}.elevation.png
        const TileId id{zoom, x, std::stoi(file.path().stem().string())};
        const auto base = layer / std::to_string(zoom) / std::to_string(x) / file.path().stem();
        Tile tile{test::readTile(layer, id), ts::readGlb(base.string() + ".hires.glb", false), {}};
        const int size = tile.size();
        for (int j = 0; j < size; ++j) {
          for (int i = 0; i < size; ++i) tile.texel.push_back(place(id, size, i, j));
        }
        m_tiles.emplace(id, std::move(tile));
      }
    }
  }

  const std::map<TileId, Tile>& tiles() const { return m_tiles; }

  // The bytes of one of the layer's files beside tile `id`'s ("{y}" + suffix).
  std::string fileBeside(const TileId& id, const std::string& suffix) const {
    return test::readBytes(m_layer / std::to_string(id.z) / std::to_string(id.x) / (std::to_string(id.y) + suffix));
  }

  // A point of a tile in texel coordinates (texel (i, j)'s centre at (i, j)).
  Place place(const TileId& tile, int size, double i, double j) const {
    const glm::dvec2 px = m_geometry.pixelOf(test::webMercatorTexelLonLat(tile, size, i, j));
    const double px_per_texel = glm::length(m_geometry.pixelOf(test::webMercatorTexelLonLat(tile, size, i + 1, j)) - px);
    const double inside_px = std::min({px.x, px.y, kDemPixels - px.x, kDemPixels - px.y});
    return {inside_px > 0, std::abs(inside_px) / px_per_texel};
  }

 private:
  std::filesystem::path m_layer;
  test::DemGeometry m_geometry;
  std::map<TileId, Tile> m_tiles;
};

config::TileJob edgeJob(const std::string& name, int zoom, NodataSurface surface) {
  config::TileJob job = test::tileJob(edgeDem(), "dem_edge/" + name, SchemeKind::kWebMercator, zoom, zoom);
  job.bits = 16;
  job.high_res_mesh = true;
  job.elevation = Elevation::kTerrarium;  // cut's are continue's (docs/CONTRACT.md §3)
  job.nodata_surface = surface;
  std::filesystem::remove_all(test::layerDir(job));  // each run bakes it afresh, whatever an earlier build left
  return job;
}

// The default layer at a zoom, made once per test process. ctest runs each
// test in a process of its own, in parallel, so each test makes it in a
// folder of its own.
const EdgeLayer& continuedLayer(int zoom) {
  static std::map<int, EdgeLayer> layers;
  const auto made = layers.find(zoom);
  if (made != layers.end()) return made->second;
  std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  std::replace(test.begin(), test.end(), '/', '_');
  const config::TileJob job = edgeJob("continue_z" + std::to_string(zoom) + "_" + test, zoom, NodataSurface::kContinue);
  EXPECT_EQ(pipeline::runTileJob(job).failed, 0);
  return layers.emplace(zoom, EdgeLayer(job)).first->second;
}

class DemEdge : public ::testing::TestWithParam<int> {};

// Calls f(tile, i, j, i2, j2) for every pair of texels next to each other
// along a row or a column of one tile.
template <class F>
void forEachNeighbourPair(const EdgeLayer& layer, F f) {
  for (const auto& [id, tile] : layer.tiles()) {
    for (int j = 0; j < tile.size(); ++j) {
      for (int i = 0; i < tile.size(); ++i) {
        if (i + 1 < tile.size()) f(tile, i, j, i + 1, j);
        if (j + 1 < tile.size()) f(tile, i, j, i, j + 1);
      }
    }
  }
}

bool wellInside(const Place& p) { return p.has_data && p.edge_texels >= kEdgeBandTexels; }

TEST_P(DemEdge, TexelsWithDataAreAsAccurateNextToTheEdgeAsInside) {
  const EdgeLayer& layer = continuedLayer(GetParam());
  std::vector<double> edge, inside;
  for (const auto& [id, tile] : layer.tiles()) {
    for (int j = 0; j < tile.size(); ++j) {
      for (int i = 0; i < tile.size(); ++i) {
        const Place& p = tile.at(i, j);
        if (!p.has_data) continue;
        const auto n = tile.decoded.ecefNormal(i, j);
        ASSERT_TRUE(n) << id.str() << " texel " << i << ", " << j;
        const glm::dvec2 lon_lat = test::webMercatorTexelLonLat(id, tile.size(), i, j);
        (p.edge_texels <= kEdgeBandTexels ? edge : inside)
            .push_back(test::angleBetweenDeg(*n, ts::normalEcef(lon_lat.x, lon_lat.y)));
      }
    }
  }
  const Stats e = summarise(edge), in = summarise(inside);
  print("error, texels within 3 of the edge (deg)", e);
  print("error, texels further in (deg)", in);
  ASSERT_GT(e.count, 1000u);
  EXPECT_LE(e.mean, kMaxEdgeMeanDeg);
  EXPECT_LE(e.p99, kMaxEdgeP99Deg);
}

TEST_P(DemEdge, SurfaceRunsOnAcrossTheEdgeWithoutAStep) {
  const EdgeLayer& layer = continuedLayer(GetParam());
  std::vector<double> across_turn, inside_turn, across_rise, inside_rise;
  forEachNeighbourPair(layer, [&](const EdgeLayer::Tile& tile, int i, int j, int i2, int j2) {
    const Place &p = tile.at(i, j), &q = tile.at(i2, j2);
    const bool across = p.has_data != q.has_data;
    if (!across && !(wellInside(p) && wellInside(q))) return;
    const double turn = test::angleBetweenDeg(*tile.decoded.ecefNormal(i, j), *tile.decoded.ecefNormal(i2, j2));
    const double rise = std::abs(tile.height(i, j) - tile.height(i2, j2));
    (across ? across_turn : inside_turn).push_back(turn);
    (across ? across_rise : inside_rise).push_back(rise);
  });
  const Stats at = summarise(across_turn), it = summarise(inside_turn);
  const Stats ar = summarise(across_rise), ir = summarise(inside_rise);
  print("normal step across the edge (deg)", at);
  print("normal step inside (deg)", it);
  print("height step across the edge (m)", ar);
  print("height step inside (m)", ir);
  ASSERT_GT(at.count, 500u);
  EXPECT_LE(at.max, kMaxAcrossToInsideNormalStep * it.max);
  EXPECT_LE(ar.max, ir.max);
}

// The low-poly mesh the viewer draws (the adaptive mesh, whatever its
// triangles): along its triangle edges, no step across the DEM's edge beyond
// the terrain's own between vertices joined inside it.
TEST_P(DemEdge, LowPolyMeshRunsOnAcrossTheEdgeWithoutAStep) {
  const EdgeLayer& layer = continuedLayer(GetParam());
  std::vector<double> across, inside;
  for (const auto& [id, tile] : layer.tiles()) {
    const ts::GlbMesh& low = tile.decoded.glb;
    const int size = tile.size();
    auto placeOf = [&, tile_id = id](std::uint32_t v) {
      return layer.place(tile_id, size, low.uv[v].x * size - 0.5, low.uv[v].y * size - 0.5);
    };
    for (std::size_t t = 0; t + 2 < low.indices.size(); t += 3) {
      for (std::size_t e = 0; e < 3; ++e) {
        const std::uint32_t a = low.indices[t + e], b = low.indices[t + (e + 1) % 3];
        const Place p = placeOf(a), q = placeOf(b);
        const double rise = std::abs(low.position[a].y - low.position[b].y);
        if (p.has_data != q.has_data) across.push_back(rise);
        if (wellInside(p) && wellInside(q)) inside.push_back(rise);
      }
    }
  }
  const Stats a = summarise(across), in = summarise(inside);
  print("low-poly height step across the edge (m)", a);
  print("low-poly height step inside (m)", in);
  ASSERT_GT(a.count, 20u);
  EXPECT_LE(a.max, in.max);
}

// Beyond the edge the continuation fades into the backdrop with no wall (a
// height step) or lip (a crease) anywhere, up to and past max_fill_px.
TEST_P(DemEdge, ContinuationFadesIntoTheBackdropWithoutAWallOrLip) {
  const EdgeLayer& layer = continuedLayer(GetParam());
  std::vector<double> fill_turn, inside_turn, fill_rise, inside_rise;
  forEachNeighbourPair(layer, [&](const EdgeLayer::Tile& tile, int i, int j, int i2, int j2) {
    const Place &p = tile.at(i, j), &q = tile.at(i2, j2);
    const bool fill = !p.has_data && !q.has_data;
    if (!fill && !(wellInside(p) && wellInside(q))) return;
    (fill ? fill_turn : inside_turn)
        .push_back(test::angleBetweenDeg(*tile.decoded.ecefNormal(i, j), *tile.decoded.ecefNormal(i2, j2)));
    (fill ? fill_rise : inside_rise).push_back(std::abs(tile.height(i, j) - tile.height(i2, j2)));
  });
  const Stats ft = summarise(fill_turn), it = summarise(inside_turn);
  const Stats fr = summarise(fill_rise), ir = summarise(inside_rise);
  print("normal step beyond the edge (deg)", ft);
  print("height step beyond the edge (m)", fr);
  ASSERT_GT(ft.count, 10000u);
  EXPECT_LE(ft.max, kMaxFadeToInsideNormalStep * it.max);
  EXPECT_LE(fr.max, ir.max);
}

// nodata.surface: cut. The same texels as the default, alpha 0 exactly where
// the DEM has no sample, and meshes whose every triangle holds a texel
// centre with data while every texel with data lies on one.
INSTANTIATE_TEST_SUITE_P(InterpolatedAndAveraged, DemEdge, ::testing::Values(kInterpolatedZoom, kAveragedZoom),
                         [](const auto& test_info) { return "zoom" + std::to_string(test_info.param); });

// The cut's alpha is judged where texels are as fine as the pixels, where a
// texel has data exactly when its centre lies on the DEM.
// With `cut`, the low-poly mesh keeps `continue`'s vertices, and its index
// buffer keeps exactly the triangles that hold a texel centre with data (on
// their edges included) or have a vertex in the square of a texel with data
// (docs/CONTRACT.md §5): judged from the DEM's own geometry, texels whose
// centre lies too near the DEM's edge to tell (kEdgeAmbiguityTexels) aside.
void expectCutKeepsTheContractsTriangles(const TileId& id, const EdgeLayer::Tile& cut,
                                         const EdgeLayer::Tile& continued) {
  const ts::GlbMesh& mesh = cut.decoded.glb;
  const ts::GlbMesh& full = continued.decoded.glb;
  ASSERT_EQ(mesh.position, full.position) << id.str() << ": cut moved or dropped vertices";
  std::set<std::array<std::uint32_t, 3>> kept;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    kept.insert({mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]});
  }
  const int size = cut.size();
  // Texel (i, j): +1 data, -1 none, 0 too near the DEM's edge to tell.
  auto data = [&](int i, int j) {
    if (i < 0 || j < 0 || i >= size || j >= size) return -1;  // another tile's texel: not this tile's data
    const Place& p = cut.at(i, j);
    return p.edge_texels < kEdgeAmbiguityTexels ? 0 : p.has_data ? 1 : -1;
  };
  int judged = 0;
  for (std::size_t t = 0; t + 2 < full.indices.size(); t += 3) {
    glm::dvec2 v[3];
    for (int k = 0; k < 3; ++k) v[k] = full.uv[full.indices[t + std::size_t(k)]] * double(size) - 0.5;
    int holds = -1;  // the best of the texels that count for this triangle
    const glm::dvec2 lo = glm::min(v[0], glm::min(v[1], v[2])), hi = glm::max(v[0], glm::max(v[1], v[2]));
    for (int j = int(std::ceil(lo.y - kOnTriangleEdgeTexels)); j <= int(std::floor(hi.y + kOnTriangleEdgeTexels)); ++j) {
      for (int i = int(std::ceil(lo.x - kOnTriangleEdgeTexels)); i <= int(std::floor(hi.x + kOnTriangleEdgeTexels));
           ++i) {
        // Twice the signed areas of the texel centre with each edge, over the whole's.
        const glm::dvec2 q(i, j);
        const auto cross = [](glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; };
        const double whole = cross(v[1] - v[0], v[2] - v[0]);
        const double w0 = cross(v[1] - q, v[2] - q) / whole, w1 = cross(v[2] - q, v[0] - q) / whole;
        if (std::min({w0, w1, 1 - w0 - w1}) >= -kOnTriangleEdgeTexels) holds = std::max(holds, data(i, j));
      }
    }
    for (const glm::dvec2& corner : v) {
      for (int j = int(std::ceil(corner.y - 0.5)); j <= int(std::floor(corner.y + 0.5)); ++j) {
        for (int i = int(std::ceil(corner.x - 0.5)); i <= int(std::floor(corner.x + 0.5)); ++i) {
          holds = std::max(holds, data(i, j));
        }
      }
    }
    if (holds == 0) continue;
    const bool is_kept = kept.count({full.indices[t], full.indices[t + 1], full.indices[t + 2]}) > 0;
    EXPECT_EQ(is_kept, holds > 0) << id.str() << " triangle " << t / 3;
    ++judged;
  }
  EXPECT_GT(judged, 0) << id.str();
}

TEST(DemEdgeCut, DrawsNothingWhereTheDemHasNoSample) {
  const config::TileJob job = edgeJob("cut", kInterpolatedZoom, NodataSurface::kCut);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const EdgeLayer cut(job);
  const EdgeLayer& continued = continuedLayer(kInterpolatedZoom);
  ASSERT_EQ(cut.tiles().size(), continued.tiles().size());
  int dropped = 0;
  for (const auto& [id, tile] : cut.tiles()) {
    const ts::PngImage& png = tile.decoded.png;
    const ts::PngImage& same = continued.tiles().at(id).decoded.png;
    ASSERT_EQ(png.channels, 4) << id.str();
    const std::uint16_t opaque = std::uint16_t((1 << png.bits) - 1);
    for (int j = 0; j < png.height; ++j) {
      for (int i = 0; i < png.width; ++i) {
        for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(png.sample(i, j, ch), same.sample(i, j, ch)) << id.str();
        const Place& p = tile.at(i, j);
        if (p.edge_texels < kEdgeAmbiguityTexels) continue;
        EXPECT_EQ(png.sample(i, j, 3), p.has_data ? opaque : 0) << id.str() << " texel " << i << ", " << j;
        if (p.has_data) {
          EXPECT_TRUE(tile.decoded.ecefNormal(i, j)) << id.str() << " texel " << i << ", " << j;
        }
      }
    }
    for (const ts::GlbMesh* mesh : {&tile.decoded.glb, &tile.high}) {
      const std::size_t full = mesh == &tile.high ? std::size_t(2 * png.width * png.width)
                                                  : continued.tiles().at(id).decoded.glb.indices.size() / 3;
      const std::size_t kept = mesh->indices.size() / 3;
      dropped += int(full - kept);
      // A kept triangle holds a texel centre with data: its centroid's texel
      // is at most the triangle's longest side away from one.
      for (std::size_t t = 0; t < kept; ++t) {
        glm::dvec2 corner[3], uv(0);
        for (int k = 0; k < 3; ++k) {
          corner[k] = mesh->uv[mesh->indices[3 * t + std::size_t(k)]];
          uv += corner[k] / 3.0;
        }
        const double triangle_texels =
            std::max({glm::distance(corner[0], corner[1]), glm::distance(corner[1], corner[2]),
                      glm::distance(corner[2], corner[0])}) * png.width;
        const Place centroid = cut.place(id, png.width, uv.x * png.width - 0.5, uv.y * png.height - 0.5);
        EXPECT_TRUE(centroid.has_data || centroid.edge_texels <= triangle_texels) << id.str();
      }
    }
  }
  EXPECT_GT(dropped, 1000);
  for (const auto& [id, tile] : cut.tiles()) {
    expectCutKeepsTheContractsTriangles(id, tile, continued.tiles().at(id));
    const std::string elevation = cut.fileBeside(id, ".elevation.png");
    EXPECT_FALSE(elevation.empty()) << id.str();
    EXPECT_EQ(elevation, continued.fileBeside(id, ".elevation.png"))
        << id.str() << ": the elevation tile under cut differs from continue's";
  }
  const std::string tilejson = test::readBytes(test::layerDir(job) / "tilejson.json");
  EXPECT_NE(tilejson.find("\"nodata_surface\": \"cut\""), std::string::npos);
  EXPECT_NE(tilejson.find("\"alpha\": true"), std::string::npos);
}

}  // namespace
}  // namespace terrabake

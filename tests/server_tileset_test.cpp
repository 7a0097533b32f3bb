// The 3D Tiles tileset of an on-demand layer, planned before its tiles
// exist and walked over HTTP as a viewer walks it (tileset_walk.hpp): every
// content URI bakes, and each baked mesh lies where the tileset's composed
// transforms put it and inside its tile's region; the tileset names the
// tiles a batch run makes; it is cached as a folder layer's is.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "io/tileset.hpp"
#include "server_helpers.hpp"
#include "tileset_walk.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using namespace test;
using Json = nlohmann::json;

// Zooms 8 to 14: seven levels, so the tileset goes on in external tilesets.
constexpr int kMinZoom = 8, kMaxZoom = 14;
static_assert(kMaxZoom - kMinZoom >= io::kTilesetLevelsPerFile);

// A serve config whose one on-demand layer is `layer`, made by the job
// file text `job` (which names the layer too).
config::ServeConfig onDemandConfig(const fs::path& dir, const std::string& layer, const std::string& job) {
  config::ServeConfig config = fakeConfig(dir);
  const fs::path file = dir / (layer + ".yaml");
  writeText(file, job);
  config.layer_jobs = {file.string()};
  return config;
}

// A tile job's text: `dem` into the layer `layer`, zooms `min_zoom` to
// `max_zoom` in tiles of `tile_size`, `more_tiling` lines under tiling:,
// then `more` (whole sections), baked on the CPU by two workers.
std::string jobText(const fs::path& dem, const std::string& layer, bool tileset, int min_zoom, int max_zoom,
                    int tile_size, const std::string& more_tiling = "", const std::string& more = "") {
  return "dem: " + dem.string() + "\noutput:\n  layer: " + layer + "\n  tileset: " + (tileset ? "true" : "false") +
         "\ntiling:\n  zoom: [" + std::to_string(min_zoom) + ", " + std::to_string(max_zoom) +
         "]\n  tile_size: " + std::to_string(tile_size) + "\n" + more_tiling + more +
         "bake:\n  backend: cpu\n  workers: 2\n";
}

// The on-demand layer "live" over the small DEM, with output.tileset as given.
config::ServeConfig liveConfig(const fs::path& dir, bool tileset) {
  return onDemandConfig(dir, "live", jobText(smallDem(), "live", tileset, kMinZoom, kMaxZoom, 32));
}

// A walk of a served layer's tileset as a viewer fetches it over HTTP; an
// on-demand layer bakes each content it names when asked for it.
TilesetWalk httpWalk(const ServerThread& running, const config::ServeConfig& config, const std::string& layer,
                     int deepest_zoom) {
  const int port = running.port();
  return TilesetWalk(fs::path(config.tiles_dir) / layer, deepest_zoom,
                     [port, layer](const std::string& path) -> std::optional<std::string> {
                       const auto reply = get(port, "/" + layer + "/" + path);
                       if (!reply || reply->status != 200) return std::nullopt;
                       return reply->body;
                     });
}

TEST(ServeOnDemandTileset, EveryTileBakesWhereTheTilesetPutsIt) {
  const fs::path dir = caseDir();
  const config::ServeConfig config = liveConfig(dir, true);
  ServerThread running(config);
  const auto tileset = get(running.port(), "/live/tileset.json");
  ASSERT_TRUE(tileset);
  ASSERT_EQ(tileset->status, 200) << tileset->body;
  EXPECT_EQ(tileset->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(Json::parse(tileset->body)["asset"]["version"], "1.1");
  EXPECT_FALSE(fs::exists(fs::path(config.tiles_dir) / "live" / std::to_string(kMaxZoom)))
      << "the tileset is planned without baking a tile";

  const fs::path layer = fs::path(config.tiles_dir) / "live";
  TilesetWalk walk = httpWalk(running, config, "live", kMaxZoom);
  walk.run();
  EXPECT_GT(walk.external_tilesets, 0) << "seven levels continue in external tilesets";
  EXPECT_EQ(walk.deepest_leaf_errors_nonzero, 0) << "the deepest zoom's tiles are the terrain itself";
  for (const auto& [id, count] : walk.meshes_seen) EXPECT_EQ(count, 1) << id.str() << " is not in the tileset once";
  RecordProperty("loosest_floor_m", std::to_string(walk.loosest_floor_m));
  RecordProperty("loosest_ceiling_m", std::to_string(walk.loosest_ceiling_m));

  // A batch run of the same job makes exactly the tiles the tileset names.
  config::TileJob batch = tileJob(smallDem(), "server_tileset/batch", SchemeKind::kWebMercator, kMinZoom, kMaxZoom);
  batch.tile_size = 32;
  batch.tileset = true;
  batch.backend = Backend::kCpu;
  fs::remove_all(layerDir(batch));
  ASSERT_EQ(pipeline::runTileJob(batch).failed, 0);
  const std::set<TileId> made = meshesOnDisk(layerDir(batch));
  std::set<TileId> named;
  for (const auto& [id, count] : walk.meshes_seen) named.insert(id);
  EXPECT_EQ(named, made);
  EXPECT_EQ(meshesOnDisk(layer), made) << "every tile the walk fetched was baked and written";
}

// Hills 100 m high on a slope rising 5 m in 100 eastwards, with a void in
// their middle, in EPSG:3857: past the DEM's corners the backdrop runs
// towards the mean of the whole DEM, away from the heights of the corner's
// own cells, and the tiles over the void carry the slopes on into it. The
// void's edges run half way across zoom-15 tiles, so that every tile the
// plan keeps has data (a tile with none answers 404).
fs::path slopingHillsWithAVoid() {
  return sharedFixture("sloping_hills_void_3857.tif", [](const fs::path& path) {
    constexpr double kWest = 1107200, kNorth = 5866840, kPixel = 20, kCentreX = 1113200, kCentreY = 5860840;
    constexpr double kHalfWorldM = 20037508.342789244, kTile15 = 2 * kHalfWorldM / 32768;
    constexpr int kPixels = 600;
    test_support::writeFloatDem(path, 3857, {kWest, kPixel, 0, kNorth, 0, -kPixel}, kPixels, kPixels,
                                [&](double x, double y) {
                                  const double column = (x + kHalfWorldM) / kTile15, row = (kHalfWorldM - y) / kTile15;
                                  if (column > 17292.5 && column < 17295.5 && row > 11589.5 && row < 11592.5) {
                                    return double(NAN);
                                  }
                                  const double dx = x - kCentreX, dy = y - kCentreY;
                                  return 800 + 100 * std::sin(2 * M_PI * dx / 3000) * std::cos(2 * M_PI * dy / 2500) +
                                         0.05 * dx;
                                });
  });
}

TEST(ServeOnDemandTileset, RegionsHoldTheMeshesPastTheDemsEdgeAndOverItsVoids) {
  const config::ServeConfig config =
      onDemandConfig(caseDir(), "hills", jobText(slopingHillsWithAVoid(), "hills", true, 13, 15, 64));
  ServerThread running(config);
  TilesetWalk walk = httpWalk(running, config, "hills", 15);
  walk.run();  // every baked mesh inside its tile's region
  EXPECT_GT(walk.meshes_seen.size(), 150u);
  RecordProperty("loosest_floor_m", std::to_string(walk.loosest_floor_m));
  RecordProperty("loosest_ceiling_m", std::to_string(walk.loosest_ceiling_m));
}

// A tiling.bbox inside the DEM: the tiles along the box's edge read the
// terrain past it, which a region must hold too, and with no hole fill
// (max_fill_px 0) nothing else widens their range.
TEST(ServeOnDemandTileset, RegionsHoldTheTerrainPastABboxEdge) {
  const fs::path sample = fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif";
  const config::ServeConfig config =
      onDemandConfig(caseDir(), "box",
                     jobText(sample, "box", true, 12, 14, 64, "  bbox: [9.95, 46.45, 10.05, 46.55]\n",
                             "nodata:\n  max_fill_px: 0\n"));
  ServerThread running(config);
  TilesetWalk walk = httpWalk(running, config, "box", 14);
  walk.run();  // every baked mesh inside its tile's region
  EXPECT_GT(walk.meshes_seen.size(), 20u);
}

// Native tiles of a DEM counted past 180 degrees, planned before they are
// baked: each planned volume lies within 3D Tiles' longitudes and holds
// the mesh baked for it, across the antimeridian (boxes) too.
TEST(ServeOnDemandTileset, VolumesHoldTheMeshesAcrossTheAntimeridian) {
  const config::ServeConfig config = onDemandConfig(
      caseDir(), "across", jobText(acrossAntimeridianDem(), "across", true, 0, 3, 32, "  scheme: native\n"));
  ServerThread running(config);
  TilesetWalk walk = httpWalk(running, config, "across", 3);
  walk.run();
  EXPECT_GT(walk.meshes_seen.size(), 40u);
  EXPECT_GE(walk.boxes, 1);
}

// Native tiles of a polar stereographic DEM 200 km round the South Pole:
// the planned region of the tile round the pole spans every longitude and
// reaches it, and every planned region holds the mesh baked for it, to
// float32's placement of the vertices of tiles 50 to 200 km across.
TEST(ServeOnDemandTileset, RegionsHoldTheMeshesRoundAPole) {
  const fs::path dem = sharedFixture("south_pole_3031.tif", [](const fs::path& path) {
    test_support::writeFloatDem(path, 3031, {-100000, 1000, 0, 100000, 0, -1000}, 200, 200, [](double x, double y) {
      return 2800 + 150 * std::sin(x / 9000) * std::cos(y / 7000);
    });
  });
  const config::ServeConfig config =
      onDemandConfig(caseDir(), "pole", jobText(dem, "pole", true, 0, 2, 32, "  scheme: native\n"));
  ServerThread running(config);
  TilesetWalk walk = httpWalk(running, config, "pole", 2);
  walk.run();
  EXPECT_EQ(walk.meshes_seen.size(), 21u);  // zooms 0-2: 1 + 4 + 16 tiles
}

// A drone survey's DEM, 128 x 128 pixels of a centimetre in UTM, planned
// from zoom 0 in the webmercator scheme: a zoom 0 tile spans 10^9 of the
// backdrop's cells and 10^10 of the height bounds' (counts that once
// overflowed, or were walked a cell at a time). The root's region holds the
// DEM and its heights, and the tileset names the tiles a batch run makes,
// each baked where it puts it, and one tile each of zooms 18 and 19, which
// bake empty: the plan leaves out only the tiles that a file's area
// overlaps by under a quarter of a texel each way, and the DEM's 1.28 m are
// 0.39 and 0.77 of their texels, which no texel has half of. (Every tile
// of zooms 0-17 was once planned, and answered 404.)
TEST(ServeOnDemandTileset, ADemOfACentimetreIsPlannedFromZoomZero) {
  const fs::path dem = sharedFixture("drone_1cm_32632.tif", [](const fs::path& path) {
    test_support::writeFloatDem(path, 32632, {500000, 0.01, 0, 5100000, 0, -0.01}, 128, 128,
                                [](double x, double) { return 300 + 0.1 * std::sin(x / 0.09); });
  });
  constexpr int kDeepest = 24;
  const config::ServeConfig config = onDemandConfig(caseDir(), "drone", jobText(dem, "drone", true, 0, kDeepest, 32));
  ServerThread running(config);
  const auto tileset = get(running.port(), "/drone/tileset.json");
  ASSERT_TRUE(tileset);
  ASSERT_EQ(tileset->status, 200) << tileset->body;
  const Json region = Json::parse(tileset->body)["root"]["boundingVolume"]["region"];
  ASSERT_EQ(region.size(), 6u) << region;
  // Just inside the DEM's north-west corner and its south-east one, 1.28 m on.
  constexpr double kWestRad = 9.0000001 * M_PI / 180, kNorthRad = 46.0535743 * M_PI / 180;
  constexpr double kSouthRad = 46.0535629 * M_PI / 180, kEastRad = 9.0000164 * M_PI / 180;
  EXPECT_LE(region[0].get<double>(), kWestRad);
  EXPECT_LE(region[1].get<double>(), kSouthRad);
  EXPECT_GE(region[2].get<double>(), kEastRad);
  EXPECT_GE(region[3].get<double>(), kNorthRad);
  EXPECT_LE(region[4].get<double>(), 299.9);
  EXPECT_GE(region[5].get<double>(), 300.1);

  TilesetWalk walk = httpWalk(running, config, "drone", kDeepest);
  walk.unresolved_allowed = true;
  walk.run();  // every content the tileset names is baked, inside its tile's region
  std::set<int> empty_zooms;
  for (const TileId& id : walk.unresolved) empty_zooms.insert(id.z);
  EXPECT_EQ(empty_zooms, (std::set<int>{18, 19}));
  EXPECT_EQ(walk.unresolved.size(), 2u);
  config::TileJob batch = tileJob(dem, "server_tileset/drone_batch", SchemeKind::kWebMercator, 0, kDeepest);
  batch.tile_size = 32;
  batch.backend = Backend::kCpu;
  fs::remove_all(layerDir(batch));
  ASSERT_EQ(pipeline::runTileJob(batch).failed, 0);
  std::set<TileId> named;
  for (const auto& [id, count] : walk.meshes_seen) named.insert(id);
  EXPECT_EQ(named, meshesOnDisk(layerDir(batch)));
}

// The first external tileset a tileset's tile names, depth first.
std::optional<std::string> firstExternal(const Json& tile) {
  if (tile.contains("content")) {
    const std::string uri = tile["content"]["uri"];
    if (uri.rfind("tilesets/", 0) == 0) return uri;
  }
  for (const Json& child : tile.value("children", Json::array())) {
    if (std::optional<std::string> found = firstExternal(child)) return found;
  }
  return std::nullopt;
}

TEST(ServeOnDemandTileset, IsCachedAsAFolderLayersTilesetIs) {
  const fs::path dir = caseDir();
  ServerThread running(liveConfig(dir, true));
  const auto main_doc = get(running.port(), "/live/tileset.json");
  ASSERT_TRUE(main_doc && main_doc->status == 200);
  const std::optional<std::string> external = firstExternal(Json::parse(main_doc->body)["root"]);
  ASSERT_TRUE(external) << "seven levels continue in an external tileset";

  for (const std::string& url : {std::string("/live/tileset.json"), "/live/" + *external}) {
    const auto first = get(running.port(), url);
    ASSERT_TRUE(first);
    ASSERT_EQ(first->status, 200) << url << ": " << first->body;
    EXPECT_EQ(first->get_header_value("Cache-Control"), "public, max-age=3600") << url;
    const std::string etag = first->get_header_value("ETag");
    ASSERT_FALSE(etag.empty()) << url;
    const auto again = get(running.port(), url);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->body, first->body) << url << ": planned once, the same bytes every time";
    EXPECT_EQ(again->get_header_value("ETag"), etag);
    const auto unchanged = get(running.port(), url, {{"If-None-Match", etag}});
    ASSERT_TRUE(unchanged);
    EXPECT_EQ(unchanged->status, 304) << url;
    EXPECT_TRUE(unchanged->body.empty());
  }
  EXPECT_EQ(statusOf(running.port(), "/live/tilesets/20/1/1.json"), 404);
  EXPECT_EQ(health(running.port())["bakes_started"], 0) << "serving the tileset bakes nothing";

  // tilejson names it, so viewers find it.
  const Json tilejson = Json::parse(get(running.port(), "/live/tilejson.json")->body);
  EXPECT_EQ(tilejson["terrabake"]["tileset"], "http://127.0.0.1:" + std::to_string(running.port()) + "/live/tileset.json");
}

TEST(ServeOnDemandTileset, ALayerWhoseJobAsksForNoneHasNone) {
  const fs::path dir = caseDir();
  ServerThread running(liveConfig(dir, false));
  const auto reply = get(running.port(), "/live/tileset.json");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 404);
  EXPECT_NE(reply->body.find("output.tileset"), std::string::npos) << reply->body;
}

}  // namespace
}  // namespace terrabake

// The in-memory tile cache of `terrabake serve` (http.cache_mib) over HTTP: a
// hit answers what a miss does, a tile rewritten or removed on disk is never
// answered from memory, baked tiles are kept within the bound in MiB, and 0
// keeps nothing. The cache on its own: server_units_test.
#include <gtest/gtest.h>

#include <httplib.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "io/tile_files.hpp"
#include "server/served_folder.hpp"
#include "server_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using namespace test;

constexpr std::size_t kMib = 1024 * 1024;

// --- Over HTTP ---------------------------------------------------------------

// A case with only its batch-made layer "static".
Case staticCase(int cache_mib) {
  Case c = makeCase();
  c.config.layer_jobs.clear();
  c.config.cache_mib = cache_mib;
  return c;
}

TEST(ServeCache, AHitAnswersTheBytesAndHeadersOfTheMiss) {
  const Case c = staticCase(64);
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  int requests = 0;
  for (const std::string extension : {"png", "glb", "hires.glb"}) {
    SCOPED_TRACE(extension);
    const std::string url = tileUrl("static", tile, extension);
    const auto miss = get(running.port(), url);
    const auto hit = get(running.port(), url);
    requests += 2;
    ASSERT_TRUE(miss && hit);
    EXPECT_EQ(hit->status, 200);
    EXPECT_EQ(hit->body, readBytes(c.tiles / "static" / (tile.str() + "." + extension)));
    EXPECT_EQ(hit->body, miss->body);
    for (const char* header : {"ETag", "Content-Type", "Content-Length", "Cache-Control", "Accept-Ranges",
                               "Access-Control-Allow-Origin"}) {
      EXPECT_EQ(hit->get_header_value(header), miss->get_header_value(header)) << header;
    }
    const auto unchanged = get(running.port(), url, {{"If-None-Match", miss->get_header_value("ETag")}});
    ++requests;
    ASSERT_TRUE(unchanged);
    EXPECT_EQ(unchanged->status, 304);
  }
  const auto counters = health(running.port());
  EXPECT_EQ(counters["tile_cache_tiles"], 3);
  EXPECT_EQ(counters["tile_cache_misses"], 3) << "one read from disk per file";
  EXPECT_EQ(counters["tile_cache_hits"], requests - 3);
  EXPECT_GT(counters["tile_cache_bytes"], 0);
}

TEST(ServeCache, ATileChangedOnDiskIsNeverAnsweredFromMemory) {
  const Case c = staticCase(64);
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  const std::string url = tileUrl("static", tile, "png");
  const fs::path png = c.tiles / "static" / (tile.str() + ".png");
  const auto first = get(running.port(), url);
  ASSERT_TRUE(first && get(running.port(), url));
  ASSERT_EQ(health(running.port())["tile_cache_hits"], 1);

  // Replaced as terrabake replaces files: a new file renamed into place.
  const std::string renamed = first->body + "renamed";
  writeBytes(png.string() + ".new", renamed);
  fs::rename(png.string() + ".new", png);
  const auto after_rename = get(running.port(), url);
  ASSERT_TRUE(after_rename);
  EXPECT_EQ(after_rename->status, 200);
  EXPECT_EQ(after_rename->body, renamed);
  EXPECT_NE(after_rename->get_header_value("ETag"), first->get_header_value("ETag"));
  // The client holding the old version is not told it is current.
  const auto old_tag = get(running.port(), url, {{"If-None-Match", first->get_header_value("ETag")}});
  ASSERT_TRUE(old_tag);
  EXPECT_EQ(old_tag->status, 200);
  EXPECT_EQ(old_tag->body, renamed);

  // Rewritten in place, with another size.
  const std::string rewritten = "rewritten in place";
  writeBytes(png, rewritten);
  const auto after_rewrite = get(running.port(), url);
  ASSERT_TRUE(after_rewrite);
  EXPECT_EQ(after_rewrite->body, rewritten);

  // Removed, then a link out of the layer in its place.
  fs::remove(png);
  EXPECT_EQ(statusOf(running.port(), url), 404);
  fs::create_symlink(c.dir / "secret.txt", png);
  const auto linked = get(running.port(), url);
  ASSERT_TRUE(linked);
  EXPECT_EQ(linked->status, 404);
  EXPECT_EQ(linked->body.find(kSecret), std::string::npos);
}

TEST(ServeCache, ZeroMibKeepsNothing) {
  const Case c = staticCase(0);
  ServerThread running(c.config);
  const std::string url = tileUrl("static", c.someTile(), "png");
  const auto first = get(running.port(), url);
  const auto second = get(running.port(), url);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(second->status, 200);
  EXPECT_EQ(second->body, first->body);
  EXPECT_EQ(second->get_header_value("ETag"), first->get_header_value("ETag"));
  const auto counters = health(running.port());
  EXPECT_EQ(counters["tile_cache_tiles"], 0);
  EXPECT_EQ(counters["tile_cache_bytes"], 0);
  EXPECT_EQ(counters["tile_cache_hits"], 0);
  EXPECT_EQ(counters["tile_cache_misses"], 0);
}

TEST(ServeCache, BakedTilesAreKeptWithinTheBoundInMib) {
  // Tiles of 300 KiB: three fit in 1 MiB, four do not.
  constexpr std::size_t kTileBytes = 300 * 1024;
  constexpr int kTiles = 6;
  const fs::path dir = caseDir();
  auto layer = fakeLayer(dir / "tiles", 1, 8, [](const TileId& tile) -> std::optional<io::TileFiles> {
    io::TileFiles files = fakeFiles();
    files.png.resize(kTileBytes, std::uint8_t(tile.y));
    return files;
  });
  config::ServeConfig config = fakeConfig(dir);
  config.cache_mib = 1;
  ServerThread running(config, onlyLayer(std::move(layer)));
  for (int y = 0; y < kTiles; ++y) {
    const auto reply = get(running.port(), "/fake/5/1/" + std::to_string(y) + ".png");
    ASSERT_TRUE(reply);
    ASSERT_EQ(reply->status, 200);
    EXPECT_EQ(reply->body.size(), kTileBytes);
    const auto counters = health(running.port());
    EXPECT_LE(counters["tile_cache_bytes"].get<std::size_t>(), kMib);
    EXPECT_EQ(counters["tile_cache_tiles"], std::min(y + 1, 3));
  }
  // The last one baked is answered from memory, with the bytes and ETag of the file it wrote.
  const std::string last = "/fake/5/1/" + std::to_string(kTiles - 1) + ".png";
  const auto hit = get(running.port(), last);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->body, readBytes(dir / "tiles" / "fake" / "5" / "1" / (std::to_string(kTiles - 1) + ".png")));
  EXPECT_EQ(hit->get_header_value("ETag"),
            server::ServedFolder(dir / "tiles" / "fake").etag("5/1/" + std::to_string(kTiles - 1) + ".png"));
  const auto counters = health(running.port());
  EXPECT_EQ(counters["tile_cache_hits"], 1);
  EXPECT_EQ(counters["bakes_started"], kTiles);
}

}  // namespace
}  // namespace terrabake

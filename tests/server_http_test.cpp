// `terrabake serve` in process, on an ephemeral port, answering over HTTP:
// routes, status codes, caching and CORS headers, path traversal over raw
// sockets, layers that cannot be served, and on-demand bakes (shared, 503,
// 500, the bytes of a batch run, stop).
#include <gtest/gtest.h>

#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "core/error.hpp"
#include "gl_test_support.hpp"
#include "server/layer_catalog.hpp"
#include "server/on_demand_layer.hpp"
#include "server/server.hpp"
#include "sanitizers.hpp"
#include "server_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using namespace test;
using Json = nlohmann::json;

// For the paths httplib::Client would not send as written: one request on a
// plain socket, the status and everything the server said.
struct RawReply {
  int status = 0;
  std::string text;
};

RawReply rawGet(int port, const std::string& target) {
  RawReply reply;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("socket failed");
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(uint16_t(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const timeval timeout{30, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
    const std::string request = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
    if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == ssize_t(request.size())) {
      char buffer[4096];
      for (ssize_t got; (got = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) reply.text.append(buffer, std::size_t(got));
    }
  }
  ::close(fd);
  if (startsWith(reply.text, "HTTP/1.1 ")) reply.status = std::stoi(reply.text.substr(9, 3));
  return reply;
}

TEST(ServeHttp, HealthCountsLayersAndBakes) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const auto reply = get(running.port(), "/health");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  EXPECT_EQ(reply->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(reply->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Origin"), "*");
  const Json body = Json::parse(reply->body);
  EXPECT_EQ(body["status"], "ok");
  EXPECT_EQ(body["layers"], 2);
  EXPECT_EQ(body["bakes_started"], 0);
  EXPECT_EQ(body["bakes_joined"], 0);
}

TEST(ServeHttp, APortInUseIsAnError) {
  const Case c = makeCase();
  ServerThread running(c.config);
  config::ServeConfig second = c.config;
  second.port = running.port();
  EXPECT_THROW(server::Server(second, {}), InputError);
}

TEST(ServeHttp, LayerListPointsAtEachTileJsonNeverFromTheHostHeader) {
  const Case c = makeCase();
  ServerThread running(c.config);
  // A forged Host would point every URL, and every cache keeping the answer, elsewhere.
  const auto reply = get(running.port(), "/layers.json", {{"Host", "evil.example:666"}});
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  EXPECT_EQ(reply->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(reply->body.find("evil.example"), std::string::npos) << reply->body;
  const Json body = Json::parse(reply->body);
  ASSERT_EQ(body["layers"].size(), 2u);
  EXPECT_EQ(body["layers"][0]["name"], "live");
  EXPECT_EQ(body["layers"][0]["tilejson"],
            "http://127.0.0.1:" + std::to_string(running.port()) + "/live/tilejson.json");
  EXPECT_EQ(body["layers"][0]["on_demand"], true);
  EXPECT_EQ(body["layers"][1]["name"], "static");
  EXPECT_EQ(body["layers"][1]["on_demand"], false);
}

TEST(ServeHttp, TileJsonUrlsAreAbsolute) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const std::string origin = "http://127.0.0.1:" + std::to_string(running.port());
  for (const std::string layer : {"static", "live"}) {
    const auto reply = get(running.port(), "/" + layer + "/tilejson.json");
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->status, 200);
    EXPECT_EQ(reply->get_header_value("Content-Type"), "application/json");
    EXPECT_EQ(reply->get_header_value("Cache-Control"), "no-cache");
    const Json doc = Json::parse(reply->body);
    EXPECT_EQ(doc["tiles"][0], origin + "/" + layer + "/{z}/{x}/{y}.png");
    EXPECT_EQ(doc["terrabake"]["mesh"], origin + "/" + layer + "/{z}/{x}/{y}.glb");
    EXPECT_EQ(doc["minzoom"], 11);
    EXPECT_EQ(doc["maxzoom"], 13);
    const std::string etag = reply->get_header_value("ETag");
    ASSERT_FALSE(etag.empty());
    const auto again = get(running.port(), "/" + layer + "/tilejson.json", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
  }
  // The on-demand layer wrote its tilejson.json at start.
  EXPECT_TRUE(fs::exists(c.tiles / "live" / "tilejson.json"));
}

TEST(ServeHttp, StaticTilesWithTypesValidatorsAndCaching) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  const struct {
    const char* extension;
    const char* type;
  } kinds[] = {{"png", "image/png"}, {"glb", "model/gltf-binary"}, {"hires.glb", "model/gltf-binary"}};
  for (const auto& kind : kinds) {
    const std::string url = tileUrl("static", tile, kind.extension);
    const auto reply = get(running.port(), url);
    ASSERT_TRUE(reply) << url;
    EXPECT_EQ(reply->status, 200) << url;
    EXPECT_EQ(reply->get_header_value("Content-Type"), kind.type) << url;
    EXPECT_EQ(reply->get_header_value("Cache-Control"), "public, max-age=3600") << url;
    EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Origin"), "*") << url;
    EXPECT_EQ(reply->body, readBytes(c.tiles / "static" / (tile.str() + "." + kind.extension))) << url;
    const std::string etag = reply->get_header_value("ETag");
    EXPECT_TRUE(startsWith(etag, "\"") && etag.size() > 2 && etag.back() == '"') << "a strong ETag: " << etag;

    for (const std::string& condition : {etag, "W/" + etag, "\"other\", " + etag}) {
      const auto cached = get(running.port(), url, {{"If-None-Match", condition}});
      ASSERT_TRUE(cached);
      EXPECT_EQ(cached->status, 304) << url << " If-None-Match: " << condition;
      EXPECT_EQ(cached->body, "");
      EXPECT_EQ(cached->get_header_value("ETag"), etag);
      EXPECT_EQ(cached->get_header_value("Cache-Control"), "public, max-age=3600");
    }
    const auto changed = get(running.port(), url, {{"If-None-Match", "\"not-this-one\""}});
    ASSERT_TRUE(changed);
    EXPECT_EQ(changed->status, 200);

    httplib::Client client("127.0.0.1", running.port());
    const auto head = client.Head(url.c_str());
    ASSERT_TRUE(head);
    EXPECT_EQ(head->status, 200);
    EXPECT_EQ(head->body, "");
    EXPECT_EQ(head->get_header_value("Content-Type"), kind.type);
    EXPECT_EQ(head->get_header_value("ETag"), etag);
    EXPECT_EQ(head->get_header_value("Content-Length"), std::to_string(reply->body.size()));
  }
}

// A layer that is a symlink to a folder, switched to another (a new version
// put in place whole): its tiles and tilejson are the new folder's within a
// second or two. The old folder's were once served for as long as it stayed.
TEST(ServeHttp, ALayerThatIsASymlinkFollowsItWhenSwitched) {
  const Case c = makeCase();
  const TileId tile = c.someTile();
  for (const char* version : {"v1", "v2"}) fs::copy(c.tiles / "static", c.tiles / version, fs::copy_options::recursive);
  const std::string v2_png = "not the png of v1";
  writeText(c.tiles / "v2" / (tile.str() + ".png"), v2_png);
  fs::create_symlink("v1", c.tiles / "current");
  ServerThread running(c.config);
  const std::string url = tileUrl("current", tile, "png");
  const auto before = get(running.port(), url);
  ASSERT_TRUE(before);
  EXPECT_EQ(before->body, readBytes(c.tiles / "v1" / (tile.str() + ".png")));

  fs::create_symlink("v2", c.tiles / "next");
  fs::rename(c.tiles / "next", c.tiles / "current");
  EXPECT_TRUE(waitFor([&] {
    const auto reply = get(running.port(), url);
    return reply && reply->status == 200 && reply->body == v2_png;
  }));
}

// A layer added while the server may open no more files is no absent layer
// (a 404 a cache would keep): the look for it fails, and its name is busy
// (503) until a look once descriptors are back finds it.
TEST(ServeHttp, ALayerLookedForWithNoFileDescriptorLeftIsBusyNotAbsent) {
  // UndefinedBehaviorSanitizer checks the dynamic type of the exceptions the
  // server catches with files it opens, for which none would be left.
  if (test::kAddressSanitizer) GTEST_SKIP() << "the sanitizers need file descriptors of their own";
  const Case c = makeCase();
  const fs::path dir = c.dir / "served";
  fs::create_directories(dir);
  const server::LayerSet layers({}, server::lookForStoredLayers(dir.string()));
  fs::copy(c.tiles / "static", dir / "added", fs::copy_options::recursive);
  std::this_thread::sleep_for(server::LayerSet::kLookInterval);  // so that the next find looks
  test::expectBusyWithAllFilesOpen([&] { layers.find("added"); });
  EXPECT_TRUE(waitFor([&] {
    try {
      return layers.find("added") != nullptr;
    } catch (const server::UnreadableFile&) {
      return false;
    }
  }));
}

// Tile files are renamed into place without a sync, so a power cut may
// leave one empty: that is no tile, and an on-demand layer bakes it again.
TEST(ServeHttp, AnEmptyTileFileIsNoTile) {
  const Case c = makeCase();
  const TileId tile = c.someTile();
  const fs::path static_png = c.tiles / "static" / (tile.str() + ".png");
  const std::string made = readBytes(static_png);
  std::ofstream(static_png, std::ios::trunc).close();
  { const ServerThread first(c.config); }  // the on-demand layer's folder, as an earlier start leaves it
  const fs::path live_png = c.tiles / "live" / (tile.str() + ".png");
  fs::create_directories(live_png.parent_path());
  std::ofstream(live_png).close();
  ServerThread running(c.config);

  EXPECT_EQ(statusOf(running.port(), tileUrl("static", tile, "png")), 404);
  const auto baked = get(running.port(), tileUrl("live", tile, "png"));
  ASSERT_TRUE(baked);
  EXPECT_EQ(baked->status, 200);
  EXPECT_EQ(baked->body, made) << "baked again, with the bytes a batch run writes";
  EXPECT_EQ(readBytes(live_png), made);
}

TEST(ServeHttp, HeadSendsHeadersOnly) {
  const Case c = makeCase();
  ServerThread running(c.config);
  // A raw request: a client could hide a body the server wrongly sent.
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const timeval timeout{30, 0};  // a server that never closes fails the test instead of hanging it
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(uint16_t(running.port()));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  const std::string request = "HEAD " + tileUrl("static", c.someTile(), "png") +
                              " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  ASSERT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL), ssize_t(request.size()));
  std::string text;
  char buffer[4096];
  for (ssize_t got; (got = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) text.append(buffer, std::size_t(got));
  ::close(fd);
  EXPECT_TRUE(startsWith(text, "HTTP/1.1 200")) << text;
  const std::size_t end = text.find("\r\n\r\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_EQ(end + 4, text.size()) << "HEAD answered with a body";
  EXPECT_NE(text.find("Content-Type: image/png"), std::string::npos) << text;
}

TEST(ServeHttp, ViewerPageFilesAndThree) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const struct {
    const char* url;
    const char* type;
    fs::path file;
  } files[] = {
      {"/", "text/html", c.viewer / "index.html"},
      {"/viewer/viewer.js", "text/javascript", c.viewer / "viewer.js"},
      {"/viewer/style.css", "text/css", c.viewer / "style.css"},
      {"/viewer/alias.js", "text/javascript", c.viewer / "viewer.js"},
      {"/vendor/three/build/three.module.js", "text/javascript",
       c.viewer / "node_modules/three/build/three.module.js"},
      {"/vendor/three/examples/jsm/controls/OrbitControls.js", "text/javascript",
       c.viewer / "node_modules/three/examples/jsm/controls/OrbitControls.js"},
  };
  for (const auto& file : files) {
    const auto reply = get(running.port(), file.url);
    ASSERT_TRUE(reply) << file.url;
    EXPECT_EQ(reply->status, 200) << file.url;
    EXPECT_TRUE(startsWith(reply->get_header_value("Content-Type"), file.type)) << file.url;
    EXPECT_EQ(reply->get_header_value("Cache-Control"), "no-cache") << file.url;
    EXPECT_EQ(reply->body, readBytes(file.file)) << file.url;
    const auto cached = get(running.port(), file.url, {{"If-None-Match", reply->get_header_value("ETag")}});
    ASSERT_TRUE(cached);
    EXPECT_EQ(cached->status, 304) << file.url;
  }
  for (const char* missing : {"/viewer/missing.js", "/vendor/three/missing.js", "/viewer/node_modules"}) {
    const auto reply = get(running.port(), missing);
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->status, 404) << missing;
  }
}

TEST(ServeHttp, CorsOnEveryAnswerAndPreflight) {
  const Case c = makeCase();
  ServerThread running(c.config);
  for (const char* url : {"/health", "/static/a/b/c.png", "/nope/tilejson.json"}) {
    const auto reply = get(running.port(), url);
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Origin"), "*") << url;
  }
  httplib::Client client("127.0.0.1", running.port());
  httplib::Request preflight;
  preflight.method = "OPTIONS";
  preflight.path = tileUrl("static", c.someTile(), "png");
  preflight.headers = {{"Origin", "http://example.org"},
                       {"Access-Control-Request-Method", "GET"},
                       {"Access-Control-Request-Headers", "if-none-match"}};
  const auto reply = client.send(preflight);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 204);
  EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Origin"), "*");
  EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Methods"), "GET, HEAD, OPTIONS");
  EXPECT_EQ(reply->get_header_value("Access-Control-Allow-Headers"), "if-none-match");
  EXPECT_FALSE(reply->get_header_value("Access-Control-Max-Age").empty());

  // A list in two field lines is one list (RFC 9110 5.3).
  preflight.headers.emplace("Access-Control-Request-Headers", "range");
  const auto two_lines = client.send(preflight);
  ASSERT_TRUE(two_lines);
  EXPECT_EQ(two_lines->get_header_value("Access-Control-Allow-Headers"), "if-none-match, range");
}

TEST(ServeHttp, OtherMethodsAreNotAllowed) {
  const Case c = makeCase();
  ServerThread running(c.config);
  httplib::Client client("127.0.0.1", running.port());
  const auto post = client.Post("/static/tilejson.json", "x", "text/plain");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  EXPECT_EQ(post->get_header_value("Allow"), "GET, HEAD, OPTIONS");
  const auto del = client.Delete("/static/tilejson.json");
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 405);
}

// A layer across the antimeridian covers tiles at both ends of the grid:
// its tilejson bounds run west above east, and its plan holds two areas. A
// batch-made folder and an on-demand layer of the same job both answer the
// tiles of each side.
TEST(ServeHttp, ALayerAcrossTheAntimeridianServesBothSides) {
  const fs::path dir = caseDir();
  const fs::path dem = dir / "across.tif", tiles = dir / "tiles";
  test_support::writeGeographicDem(dem, 180.0, 50.0, 0.001, 0.001, 200, 200);
  config::TileJob job = smallJob(tiles, "batch");
  job.dems = {dem.string()};
  job.min_zoom = job.max_zoom = 12;
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const std::set<std::string> made = filesUnder(tiles / "batch" / "12");
  const auto rowOf = [&](int column) {
    for (const std::string& file : made) {
      if (file.rfind(std::to_string(column) + "/", 0) == 0 && fs::path(file).extension() == ".png") {
        return std::stoi(fs::path(file).stem().string());
      }
    }
    return -1;
  };
  const TileId west{12, 4095, rowOf(4095)}, east{12, 0, rowOf(0)};
  ASSERT_GE(west.y, 0);
  ASSERT_GE(east.y, 0);
  writeText(dir / "live.yaml", "dem: " + dem.string() + "\noutput:\n  layer: live\ntiling:\n  zoom: 12\n"
                                "  tile_size: 64\nbake:\n  backend: cpu\n");
  config::ServeConfig config;
  config.tiles_dir = tiles.string();
  config.layer_jobs = {(dir / "live.yaml").string()};
  config.port = 0;
  ServerThread running(config);
  for (const std::string layer : {"batch", "live"}) {
    for (const TileId& tile : {west, east}) {
      const auto reply = get(running.port(), tileUrl(layer, tile, "png"));
      ASSERT_TRUE(reply);
      EXPECT_EQ(reply->status, 200) << layer << " " << tile.str() << ": " << reply->body;
    }
  }
}

TEST(ServeHttp, MalformedTilePathsAre400) {
  const Case c = makeCase();
  ServerThread running(c.config);
  for (const char* url : {"/static/a/b/c.png", "/static/-1/0/0.png", "/static/13/-4/2.png",
                          "/static/13/4398/99999999999.png", "/static/99/0/0.png", "/static/13/1/1.jpg",
                          "/static/13/1/1.txt", "/static/13/1/1", "/static/013/1/1.png", "/static/13/1/2/3.png",
                          "/live/a/b/c.png", "/nope/a/b/c.png"}) {
    const auto reply = get(running.port(), url);
    ASSERT_TRUE(reply) << url;
    EXPECT_EQ(reply->status, 400) << url;
    EXPECT_TRUE(startsWith(reply->get_header_value("Content-Type"), "text/plain")) << url;
  }
  EXPECT_EQ(health(running.port())["bakes_started"], 0);
}

TEST(ServeHttp, OutsideZoomsOrCoverageAndUnknownLayersAre404) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  const TileId far_away{13, (tile.x + 4000) % 8192, tile.y};
  for (const std::string layer : {"static", "live"}) {
    for (const std::string& url : {tileUrl(layer, {10, 0, 0}, "png"), tileUrl(layer, {14, 0, 0}, "png"),
                                   tileUrl(layer, {5, 17, 11}, "glb"), tileUrl(layer, far_away, "png"),
                                   tileUrl(layer, {13, 9000, 1}, "png")}) {
      const auto reply = get(running.port(), url);
      ASSERT_TRUE(reply) << url;
      EXPECT_EQ(reply->status, 404) << url;
    }
  }
  for (const std::string url : {"/nope/tilejson.json", "/nope/13/1/1.png", "/favicon.ico", "/static"}) {
    const auto reply = get(running.port(), url);
    ASSERT_TRUE(reply) << url;
    EXPECT_EQ(reply->status, 404) << url;
  }
  EXPECT_EQ(health(running.port())["bakes_started"], 0) << "nothing outside a layer is baked";
}

TEST(ServeHttp, NoPathReadsOutsideTheLayerOrTheViewer) {
  const Case c = makeCase();
  // A tile turned into a symlink to the secret: inside the layer's area, outside
  // its folder. (Its mesh goes, so the glTF validator meets no broken texture.)
  const TileId tile = c.someTile();
  const fs::path linked_tile = c.tiles / "static" / (tile.str() + ".png");
  fs::remove(linked_tile);
  fs::remove(c.tiles / "static" / (tile.str() + ".glb"));
  fs::create_symlink(c.dir / "secret.txt", linked_tile);
  ASSERT_EQ(::mkfifo((c.viewer / "fifo.js").c_str(), 0644), 0);  // would block a plain open()
  ServerThread running(c.config);

  const struct {
    std::string target;
    int status;
  } attempts[] = {
      {"/viewer/../secret.txt", 400},
      {"/viewer/../../secret.txt", 400},
      {"/viewer/%2e%2e/secret.txt", 400},
      {"/viewer/%2E%2E/secret.txt", 400},
      {"/viewer/..%2fsecret.txt", 400},
      {"/viewer/%2e%2e%2fsecret.txt", 400},
      {"/viewer/%2e%2e%2f%2e%2e%2fsecret.txt", 400},
      {"/vendor/three/../../../secret.txt", 400},
      {"/vendor/three/%2e%2e/%2e%2e/%2e%2e/secret.txt", 400},
      {"/static/../secret.txt", 400},
      {"/static/%2e%2e/%2e%2e/secret.txt", 400},
      {"/static/..%2f..%2fsecret.txt", 400},
      {"//" + (c.dir / "secret.txt").string(), 400},
      {"/viewer/" + (c.dir / "secret.txt").string(), 400},  // "/viewer//abs/..." : an empty segment
      {"/viewer/%2f" + (c.dir / "secret.txt").string().substr(1), 400},
      {"/viewer/secret.txt%00.js", 400},
      {"/viewer/..\\secret.txt", 400},
      {"/viewer/escape.js", 404},                                   // a symlink pointing out
      {"/viewer/fifo.js", 404},                                     // not a regular file
      {tileUrl("static", tile, "png"), 404},                        // likewise, in a layer
      {"/" + c.dir.filename().string() + "/tilejson.json", 404},    // the case folder is no layer
      {c.dir.string() + "/secret.txt", 400},                        // an absolute path is no route
  };
  for (const auto& attempt : attempts) {
    const RawReply reply = rawGet(running.port(), attempt.target);
    EXPECT_EQ(reply.status, attempt.status) << attempt.target << "\n" << reply.text;
    EXPECT_EQ(reply.text.find(kSecret), std::string::npos) << attempt.target << " read the secret";
  }
  // Not even an absolute-form target or one without a leading slash gets near it.
  for (const std::string target : {"secret.txt", "http://127.0.0.1/viewer/../secret.txt"}) {
    const RawReply reply = rawGet(running.port(), target);
    EXPECT_NE(reply.status, 200) << target;
    EXPECT_EQ(reply.text.find(kSecret), std::string::npos) << target;
  }
}

TEST(ServeHttp, FoldersThatCannotBeLayersAreSkipped) {
  const Case c = makeCase();
  writeText(c.tiles / "broken" / "tilejson.json", "{ not json");
  writeText(c.tiles / "viewer" / "tilejson.json", R"({"minzoom": 0, "maxzoom": 1, "bounds": [0, 0, 1, 1]})");
  fs::create_directories(c.tiles / "no_tilejson");
  ServerThread running(c.config);
  EXPECT_EQ(health(running.port())["layers"], 2);
  const auto reply = get(running.port(), "/broken/tilejson.json");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 404);
}

TEST(ServeHttp, AJobMayNotTakeARouteName) {
  const Case c = makeCase();
  writeText(c.dir / "viewer.yaml", "dem: " + smallDem().string() + "\noutput:\n  layer: viewer\n" + kJobBody);
  config::ServeConfig config = c.config;
  config.layer_jobs = {(c.dir / "viewer.yaml").string()};
  EXPECT_THROW(server::openLayers(config), UsageError);
}

// --- On-demand layers ----------------------------------------------------------

TEST(ServeOnDemand, AMissingTileIsBakedWrittenAndServedAgainFromDisk) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  const fs::path png = c.tiles / "live" / (tile.str() + ".png");
  ASSERT_FALSE(fs::exists(png));

  const auto first = get(running.port(), tileUrl("live", tile, "png"));
  ASSERT_TRUE(first);
  EXPECT_EQ(first->status, 200) << first->body;
  EXPECT_EQ(first->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(first->get_header_value("Cache-Control"), "public, max-age=3600");
  EXPECT_TRUE(fs::exists(png));
  EXPECT_TRUE(fs::exists(c.tiles / "live" / (tile.str() + ".glb")));
  EXPECT_EQ(first->body, readBytes(png));

  const auto second = get(running.port(), tileUrl("live", tile, "png"));
  ASSERT_TRUE(second);
  EXPECT_EQ(second->status, 200);
  EXPECT_EQ(second->get_header_value("ETag"), first->get_header_value("ETag"));
  EXPECT_EQ(second->body, first->body);
  const auto mesh = get(running.port(), tileUrl("live", tile, "glb"));
  ASSERT_TRUE(mesh);
  EXPECT_EQ(mesh->status, 200);
  EXPECT_EQ(mesh->get_header_value("Content-Type"), "model/gltf-binary");

  const Json counters = health(running.port());
  EXPECT_EQ(counters["bakes_started"], 1) << "the second request and the mesh come from disk";
  EXPECT_EQ(counters["bakes_written"], 1);
  // No high-res meshes in this layer: not baked, not found.
  const auto hires = get(running.port(), tileUrl("live", tile, "hires.glb"));
  ASSERT_TRUE(hires);
  EXPECT_EQ(hires->status, 404);
  EXPECT_EQ(health(running.port())["bakes_started"], 1);
}

TEST(ServeOnDemand, BakesTheBytesABatchRunWrites) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  for (const char* extension : {"png", "glb"}) {
    const auto reply = get(running.port(), tileUrl("live", tile, extension));
    ASSERT_TRUE(reply);
    ASSERT_EQ(reply->status, 200);
    EXPECT_EQ(reply->body, readBytes(c.tiles / "static" / (tile.str() + "." + extension))) << extension;
  }
}

TEST(ServeOnDemand, ConcurrentRequestsForOneTileShareOneBake) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  constexpr int kClients = 8;
  std::vector<std::thread> clients;
  std::vector<int> statuses(kClients);
  std::vector<std::string> etags(kClients);
  for (int i = 0; i < kClients; ++i) {
    clients.emplace_back([&, i] {
      const auto reply = get(running.port(), tileUrl("live", tile, "png"));
      statuses[i] = reply ? reply->status : -1;
      if (reply) etags[i] = reply->get_header_value("ETag");
    });
  }
  for (auto& client : clients) client.join();
  for (int i = 0; i < kClients; ++i) {
    EXPECT_EQ(statuses[i], 200) << "client " << i;
    EXPECT_EQ(etags[i], etags[0]) << "client " << i;
  }
  EXPECT_EQ(health(running.port())["bakes_started"], 1);
}

TEST(ServeOnDemand, RequestsWaitingOnOneHeldBakeShareIt) {
  const fs::path dir = caseDir();
  Gate gate;
  std::atomic<int> bakes{0};
  auto layer = fakeLayer(dir / "tiles", 2, 8, [&](const TileId&) {
    ++bakes;
    gate.pass();
    return std::optional<io::TileFiles>(fakeFiles());
  });
  server::LayerSource* fake = layer.get();
  ServerThread running(fakeConfig(dir), onlyLayer(std::move(layer)));
  std::vector<std::thread> clients;
  std::vector<int> statuses(4);
  for (int i = 0; i < 4; ++i) {
    clients.emplace_back([&, i] { statuses[i] = statusOf(running.port(), "/fake/7/3/5.png"); });
  }
  // While the gate holds the first request's bake, the tile is nowhere on
  // disk: the three other requests can only be answered by joining that bake.
  const bool entered = gate.waitEntered(1);
  const bool all_joined = entered && waitFor([&] { return fake->bakeCounters().joined == 3; });
  const std::uint64_t joined_while_held = fake->bakeCounters().joined;
  gate.open();
  for (auto& client : clients) client.join();
  ASSERT_TRUE(entered);
  EXPECT_TRUE(all_joined) << joined_while_held << " of 3 requests joined the held bake within "
                          << kWaitLimit.count() << " s";
  EXPECT_EQ(statuses, std::vector<int>(4, 200));
  EXPECT_EQ(bakes, 1);
  EXPECT_EQ(fake->bakeCounters().started, 1u);
  EXPECT_EQ(fake->bakeCounters().joined, 3u);
  EXPECT_EQ(health(running.port())["bakes_joined"], 3);
}

TEST(ServeOnDemand, AFullQueueAnswers503WithRetryAfter) {
  const fs::path dir = caseDir();
  Gate gate;
  auto layer = fakeLayer(dir / "tiles", 1, 1, [&](const TileId&) {
    gate.pass();
    return std::optional<io::TileFiles>(fakeFiles());
  });
  server::LayerSource* fake = layer.get();
  config::ServeConfig config = fakeConfig(dir);
  config.retry_after_s = 7;
  ServerThread running(config, onlyLayer(std::move(layer)));

  int baking_status = 0, waiting_status = 0;
  std::thread baking([&] { baking_status = statusOf(running.port(), "/fake/5/0/0.png"); });
  ASSERT_TRUE(gate.waitEntered(1));  // the only worker holds the first tile
  std::thread waiting([&] { waiting_status = statusOf(running.port(), "/fake/5/0/1.png"); });
  ASSERT_TRUE(waitFor([&] { return fake->bakeCounters().waiting == 1; }));  // the queue is full

  const auto refused = get(running.port(), "/fake/5/1/0.png");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 503);
  EXPECT_EQ(refused->get_header_value("Retry-After"), "7");
  EXPECT_EQ(refused->get_header_value("Access-Control-Allow-Origin"), "*");
  gate.open();
  baking.join();
  waiting.join();
  EXPECT_EQ(baking_status, 200);
  EXPECT_EQ(waiting_status, 200);
  EXPECT_EQ(health(running.port())["bakes_rejected"], 1);
  EXPECT_FALSE(fs::exists(dir / "tiles" / "fake" / "5" / "1" / "0.png"));
}

TEST(ServeOnDemand, AFailedBakeAnswers500AndKeepsNothing) {
  const Case c = makeCase();
  // A file where the zoom-13 folder would go: the bake works, writing it fails.
  // (Tests run as root, where permissions stop nothing.)
  { const ServerThread first(c.config); }  // the on-demand layer's folder, as an earlier start leaves it
  writeText(c.tiles / "live" / "13", "a file, not a folder\n");
  ServerThread running(c.config);
  const TileId tile = c.someTile();
  for (int attempt = 1; attempt <= 2; ++attempt) {
    const auto reply = get(running.port(), tileUrl("live", tile, "png"));
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->status, 500) << reply->body;
    EXPECT_EQ(reply->get_header_value("Cache-Control"), "no-store");
    EXPECT_EQ(health(running.port())["bakes_started"], attempt) << "a failure is not cached";
  }
  EXPECT_EQ(health(running.port())["bakes_failed"], 2);
  EXPECT_EQ(filesUnder(c.tiles / "live"), (std::set<std::string>{"13", "terrabake-job.txt", "tilejson.json"}));
}

TEST(ServeOnDemand, AnInjectedFailureAnswers500AndLeavesNoFile) {
  const fs::path dir = caseDir();
  auto layer = fakeLayer(dir / "tiles", 1, 4, [](const TileId&) -> std::optional<io::TileFiles> {
    throw std::runtime_error("injected failure");
  });
  ServerThread running(fakeConfig(dir), onlyLayer(std::move(layer)));
  const auto reply = get(running.port(), "/fake/4/2/3.glb");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 500);
  EXPECT_NE(reply->body.find("tile 4/2/3: the bake failed"), std::string::npos) << reply->body;
  EXPECT_EQ(reply->body.find("injected failure"), std::string::npos) << "the reason is for the log: " << reply->body;
  EXPECT_EQ(filesUnder(dir / "tiles" / "fake"), (std::set<std::string>{"terrabake-job.txt", "tilejson.json"}));
}

TEST(ServeOnDemand, ATileWithoutDemSamplesIs404) {
  const fs::path dir = caseDir();
  auto layer = fakeLayer(dir / "tiles", 1, 4, [](const TileId&) { return std::optional<io::TileFiles>(); });
  ServerThread running(fakeConfig(dir), onlyLayer(std::move(layer)));
  const auto reply = get(running.port(), "/fake/4/2/3.png");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 404);
  EXPECT_EQ(health(running.port())["bakes_empty"], 1);
}

TEST(ServeOnDemand, BakesWithTheDefaultBackend) {
  const Case c = makeCase("auto");
  std::vector<std::unique_ptr<server::LayerSource>> layers;
  try {
    layers = server::openLayers(c.config);
  } catch (const InputError& e) {
    if (test::glRequired()) FAIL() << "GL backend required but unavailable: " << e.what();
    GTEST_SKIP() << "no GL context on this machine: " << e.what();
  }
  ServerThread running(c.config, std::move(layers));
  const TileId tile = c.someTile();
  const auto reply = get(running.port(), tileUrl("live", tile, "png"));
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200) << reply->body;
  EXPECT_TRUE(startsWith(reply->body, "\x89PNG"));
  EXPECT_TRUE(fs::exists(c.tiles / "live" / (tile.str() + ".glb")));
}

TEST(ServeOnDemand, StopFinishesTheRunningBakeAndAbandonsQueuedOnes) {
  const fs::path dir = caseDir();
  Gate gate;
  auto layer = fakeLayer(dir / "tiles", 1, 4, [&](const TileId&) {
    gate.pass();
    return std::optional<io::TileFiles>(fakeFiles());
  });
  server::LayerSource* fake = layer.get();
  ServerThread running(fakeConfig(dir), onlyLayer(std::move(layer)));
  int running_status = 0, queued_status = 0;
  std::thread running_client([&] { running_status = statusOf(running.port(), "/fake/6/1/1.png"); });
  ASSERT_TRUE(gate.waitEntered(1));
  std::thread queued_client([&] { queued_status = statusOf(running.port(), "/fake/6/1/2.png"); });
  ASSERT_TRUE(waitFor([&] { return fake->bakeCounters().waiting == 1; }));

  std::thread stopper([&] { running.server().stop(); });
  queued_client.join();
  EXPECT_EQ(queued_status, 503) << "a queued bake is abandoned";
  gate.open();
  running_client.join();
  stopper.join();
  EXPECT_EQ(running_status, 200) << "a running bake finishes and is answered";
  EXPECT_EQ(filesUnder(dir / "tiles" / "fake"),
            (std::set<std::string>{"terrabake-job.txt", "tilejson.json", "6/1/1.png", "6/1/1.glb"}));
}

}  // namespace
}  // namespace terrabake

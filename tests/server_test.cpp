// Tests of `terrabake serve`: the serve config, the router, the bake queue,
// and a real server on an ephemeral port answering over HTTP (routes, status
// codes, caching and CORS headers, path traversal, on-demand bakes, shutdown),
// then the executable itself started and stopped with SIGTERM.
#include <gtest/gtest.h>

#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "child_process.hpp"
#include "file_helpers.hpp"
#include "gl_test_support.hpp"
#include "layer_check.hpp"
#include "pipeline/tile_job_runner.hpp"
#include "server/bake_queue.hpp"
#include "server/http_rules.hpp"
#include "server/layer_catalog.hpp"
#include "server/on_demand_layer.hpp"
#include "server/route.hpp"
#include "server/server.hpp"
#include "support/analytic_terrain.hpp"

extern char** environ;

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using test::filesUnder;
using test::readBytes;
using test::writeText;
using Json = nlohmann::json;
using server::Route;
using io::TileFormat;

const fs::path kSourceDir = fs::path(TERRABAKE_SOURCE_DIR).lexically_normal();

// Long enough for a bake on a loaded 2-core machine; a hang fails instead of blocking the run.
constexpr auto kWaitLimit = std::chrono::seconds(60);
// SIGTERM to exit: the keep-alive timeout (2 s) plus room for a loaded machine.
constexpr auto kStopLimit = std::chrono::seconds(10);
// What the fixture's secret file holds: no response may ever contain it.
constexpr const char* kSecret = "terrabake-server-test-secret";

// A fresh, empty folder for the running test.
fs::path caseDir() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name = std::string(info->test_suite_name()) + "." + info->name();
  const fs::path dir = fs::path(TERRABAKE_TEST_OUTPUT) / "server" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

bool startsWith(const std::string& text, const std::string& start) { return text.rfind(start, 0) == 0; }

// The small analytic DEM of the brief: 128 x 128 pixels of 30 m in UTM 33N at 60 degrees north.
fs::path smallDem() {
  return test::sharedFixture("analytic_utm33_128.tif", [](const fs::path& path) {
    test_support::writeUtmDem(path, 15.3, 60.0, 30.0, 128, 128);
  });
}

// Small and fast: 64-texel tiles, the CPU baker, zooms where the DEM spans a few tiles.
constexpr const char* kJobBody =
    "tiling:\n  zoom: [11, 13]\n  tile_size: 64\n";

config::TileJob smallJob(const fs::path& tiles, const std::string& layer) {
  config::TileJob job;
  job.dems = {smallDem().string()};
  job.output_dir = tiles.string();
  job.layer = layer;
  job.min_zoom = 11;
  job.max_zoom = 13;
  job.zoom_set = true;
  job.tile_size = 64;
  job.backend = Backend::kCpu;
  job.workers = 2;
  return job;
}

// A test case's world: a tiles folder with a batch-made layer "static" (with
// high-res meshes), a job file for an on-demand layer "live", a viewer folder,
// and a secret file next to them that no request may read.
struct Case {
  fs::path dir;
  fs::path tiles;
  fs::path viewer;
  fs::path live_job;
  config::ServeConfig config;

  // A tile that exists in "static": the first png at zoom 13.
  TileId someTile() const {
    for (const auto& entry : fs::recursive_directory_iterator(tiles / "static" / "13")) {
      if (entry.path().extension() == ".png" && entry.path().stem().extension().empty()) {
        return {13, std::stoi(entry.path().parent_path().filename().string()), std::stoi(entry.path().stem().string())};
      }
    }
    throw std::runtime_error("no zoom-13 tile in the static layer");
  }
};

std::string tileUrl(const std::string& layer, const TileId& tile, const std::string& extension) {
  return "/" + layer + "/" + tile.str() + "." + extension;
}

Case makeCase(const std::string& live_backend = "cpu") {
  Case c;
  c.dir = caseDir();
  c.tiles = c.dir / "tiles";
  c.viewer = c.dir / "viewer";
  writeText(c.dir / "secret.txt", kSecret);

  config::TileJob job = smallJob(c.tiles, "static");
  job.high_res_mesh = true;
  pipeline::runTileJob(job);

  writeText(c.viewer / "index.html", "<!doctype html><title>viewer</title>\n");
  writeText(c.viewer / "viewer.js", "export const viewer = 1;\n");
  writeText(c.viewer / "style.css", "body { margin: 0; }\n");
  writeText(c.viewer / "node_modules/three/build/three.module.js", "export const REVISION = 'test';\n");
  writeText(c.viewer / "node_modules/three/examples/jsm/controls/OrbitControls.js", "export class OrbitControls {}\n");
  fs::create_symlink(c.dir / "secret.txt", c.viewer / "escape.js");  // points out of the viewer
  fs::create_symlink("viewer.js", c.viewer / "alias.js");             // stays inside: fine

  c.live_job = c.dir / "live.yaml";
  writeText(c.live_job, "dem: " + smallDem().string() + "\noutput:\n  layer: live\n" + kJobBody +
                            "bake:\n  backend: " + live_backend + "\n  workers: 2\n");

  c.config.tiles_dir = c.tiles.string();
  c.config.layer_jobs = {c.live_job.string()};
  c.config.port = 0;
  c.config.viewer_dir = c.viewer.string();
  return c;
}

// A server on an ephemeral port, run on a thread of its own; the destructor is
// the scope guard that stops and joins it, whatever the test did.
class ServerThread {
 public:
  ServerThread(const config::ServeConfig& config, std::vector<std::unique_ptr<server::LayerSource>> layers)
      : m_server(config, std::move(layers)), m_thread([this] { m_server.run(); }) {}
  explicit ServerThread(const config::ServeConfig& config) : ServerThread(config, server::openLayers(config)) {}
  ~ServerThread() {
    m_server.stop();
    m_thread.join();
  }
  server::Server& server() { return m_server; }
  int port() const { return m_server.port(); }

 private:
  server::Server m_server;
  std::thread m_thread;
};

httplib::Result get(int port, const std::string& path, const httplib::Headers& headers = {}) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(std::chrono::duration_cast<std::chrono::seconds>(kWaitLimit).count());
  return client.Get(path.c_str(), headers);
}

int statusOf(int port, const std::string& path) {
  const auto reply = get(port, path);
  return reply ? reply->status : -1;
}

Json health(int port) {
  const auto reply = get(port, "/health");
  if (!reply || reply->status != 200) throw std::runtime_error("GET /health failed");
  return Json::parse(reply->body);
}

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

// A gate a test holds a bake at: the bake enters and waits until the test opens it.
class Gate {
 public:
  void pass() {
    std::unique_lock<std::mutex> lock(m_mutex);
    ++m_entered;
    m_changed.notify_all();
    m_changed.wait(lock, [this] { return m_open; });
  }
  bool waitEntered(int count) {
    std::unique_lock<std::mutex> lock(m_mutex);
    return m_changed.wait_for(lock, kWaitLimit, [&] { return m_entered >= count; });
  }
  void open() {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_open = true;
    m_changed.notify_all();
  }

 private:
  std::mutex m_mutex;
  std::condition_variable m_changed;
  int m_entered = 0;
  bool m_open = false;
};

bool waitFor(const std::function<bool()>& condition) {
  const auto deadline = std::chrono::steady_clock::now() + kWaitLimit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// An on-demand layer whose tiles come from `make` instead of a DEM, over every zoom.
std::unique_ptr<server::OnDemandLayer> fakeLayer(const fs::path& tiles, int workers, std::size_t queue_size,
                                                 server::OnDemandLayer::MakeTile make) {
  server::OnDemandLayer::Settings settings{"fake",
                                           tiles / "fake",
                                           R"({"tilejson": "3.0.0", "tiles": ["./{z}/{x}/{y}.png"]})",
                                           server::TileCoverage(0, 24),
                                           false,
                                           workers,
                                           queue_size};
  return std::make_unique<server::OnDemandLayer>(std::move(settings), [make] { return make; });
}

// The smallest valid glTF binary (the validator checks every .glb the tests write).
std::vector<std::uint8_t> minimalGlb() {
  std::string json = R"({"asset":{"version":"2.0"}})";
  json.resize((json.size() + 3) / 4 * 4, ' ');
  const auto word = [](std::vector<std::uint8_t>& out, std::uint32_t value) {
    for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(value >> (8 * i)));
  };
  std::vector<std::uint8_t> glb;
  word(glb, 0x46546C67);  // "glTF"
  word(glb, 2);
  word(glb, std::uint32_t(12 + 8 + json.size()));
  word(glb, std::uint32_t(json.size()));
  word(glb, 0x4E4F534A);  // "JSON"
  glb.insert(glb.end(), json.begin(), json.end());
  return glb;
}

io::TileFiles fakeFiles() {
  io::TileFiles files;
  const std::string png = "\x89PNG fake";
  files.png.assign(png.begin(), png.end());
  files.glb = minimalGlb();
  return files;
}

config::ServeConfig fakeConfig(const fs::path& dir) {
  config::ServeConfig config;
  config.tiles_dir = (dir / "tiles").string();
  fs::create_directories(config.tiles_dir);
  config.port = 0;
  config.viewer_dir = (dir / "no_viewer").string();
  return config;
}

// --- The serve config --------------------------------------------------------

TEST(ServeConfig, LoadsTheSampleServeFile) {
  const std::string path = (kSourceDir / "config" / "serve.yaml").string();
  const config::ServeConfig config = config::loadServeConfig(path);
  EXPECT_EQ(config.tiles_dir, (kSourceDir / "tiles").string());
  EXPECT_EQ(config.layer_jobs, std::vector<std::string>{(kSourceDir / "config" / "sample.yaml").string()});
  EXPECT_EQ(config.bind, "127.0.0.1");
  EXPECT_EQ(config.port, 8080);
  EXPECT_EQ(config.tile_max_age_s, 3600);
  EXPECT_NO_THROW(config::validate(config, path));
}

TEST(ServeConfig, DefaultsBindToThisMachineAndServeTheBuiltInViewer) {
  const config::ServeConfig config;
  EXPECT_EQ(config.bind, "127.0.0.1");
  EXPECT_TRUE(config.layer_jobs.empty());
  EXPECT_EQ(fs::path(config.viewer_dir), kSourceDir / "src" / "server" / "viewer");
  EXPECT_NO_THROW(config::validate(config, "defaults"));
}

TEST(ServeConfig, ReadmeDocumentsEveryKey) {
  const std::string readme = readBytes(kSourceDir / "config" / "README.md");
  ASSERT_FALSE(readme.empty()) << "config/README.md is missing";
  for (const config::KeyInfo& key : config::listServeKeys()) {
    EXPECT_NE(readme.find("`" + key.name + "`"), std::string::npos) << key.name << " is not in config/README.md";
  }
}

TEST(ServeConfig, ErrorsNameFileLineAndKey) {
  const fs::path dir = caseDir();
  const fs::path path = dir / "serve.yaml";
  writeText(path, "tiles: t\nhttp:\n  port: 70000\n");
  try {
    config::loadServeConfig(path.string());
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":3: http.port: must be between 0 and 65535, got 70000");
  }
  writeText(path, "htp:\n  port: 1\n");
  try {
    config::loadServeConfig(path.string());
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":1: htp: unknown key (did you mean 'http'?)");
  }
  config::ServeConfig config;
  try {
    config::applyOverride(config, "http.bind", "a host", "--bind");
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), "--bind: http.bind: must be an IP address or a host name, got 'a host'");
  }
}

TEST(ServeConfig, EmptyFileMeansDefaultsAndLayersMayBeAnEmptyList) {
  const fs::path dir = caseDir();
  writeText(dir / "empty.yaml", "");
  EXPECT_EQ(config::loadServeConfig((dir / "empty.yaml").string()).port, 8080);
  writeText(dir / "none.yaml", "layers: []\n");
  EXPECT_TRUE(config::loadServeConfig((dir / "none.yaml").string()).layer_jobs.empty());
}

// --- Routes and HTTP rules, without a server ----------------------------------

TEST(ServeRoutes, KnownRoutes) {
  EXPECT_EQ(server::parseRoute("/").kind, Route::Kind::kViewerPage);
  EXPECT_EQ(server::parseRoute("/health").kind, Route::Kind::kHealth);
  EXPECT_EQ(server::parseRoute("/layers.json").kind, Route::Kind::kLayerList);
  const Route viewer = server::parseRoute("/viewer/lib/viewer.js");
  EXPECT_EQ(viewer.kind, Route::Kind::kViewerFile);
  EXPECT_EQ(viewer.file, "lib/viewer.js");
  const Route three = server::parseRoute("/vendor/three/examples/jsm/controls/OrbitControls.js");
  EXPECT_EQ(three.kind, Route::Kind::kVendorFile);
  EXPECT_EQ(three.file, "examples/jsm/controls/OrbitControls.js");
  const Route tilejson = server::parseRoute("/sample/tilejson.json");
  EXPECT_EQ(tilejson.kind, Route::Kind::kTileJson);
  EXPECT_EQ(tilejson.layer, "sample");
  const Route tile = server::parseRoute("/sample/12/2161/1448.hires.glb");
  ASSERT_EQ(tile.kind, Route::Kind::kTile);
  EXPECT_EQ(tile.layer, "sample");
  EXPECT_EQ(tile.tile, (TileId{12, 2161, 1448}));
  EXPECT_EQ(tile.format, io::TileFormat::kHighResGlb);
  EXPECT_EQ(server::parseRoute("/sample/0/0/0.png").format, io::TileFormat::kPng);
  EXPECT_EQ(server::parseRoute("/sample/0/0/0.glb").format, io::TileFormat::kGlb);
}

TEST(ServeRoutes, MalformedPathsAreBadRequests) {
  for (const char* path :
       {"/sample/a/b/c.png", "/sample/-1/0/0.png", "/sample/12/-5/3.png", "/sample/12/1/99999999999.png",
        "/sample/25/0/0.png", "/sample/12/1/1.jpg", "/sample/12/1/1", "/sample/12/1/1.", "/sample/012/1/1.png",
        "/sample/+3/1/1.png", "/sample/12/1/2/3.png", "/sample/12/1", "/sample/../etc/passwd", "/viewer/../x",
        "/viewer/./x", "//etc/passwd", "/viewer//etc/passwd", "/vendor/three/../../x", "/viewer/a\\b",
        "/sample/12/1/1.png/", "relative/path", "/a b/tilejson.json"}) {
    EXPECT_EQ(server::parseRoute(path).kind, Route::Kind::kBadRequest) << path;
  }
  EXPECT_EQ(server::parseRoute(std::string("/viewer/a\0b", 11)).kind, Route::Kind::kBadRequest);
  EXPECT_EQ(server::parseRoute("/viewer/a\nb").kind, Route::Kind::kBadRequest);
}

TEST(ServeRoutes, UnknownPathsAreNotFound) {
  for (const char* path : {"/favicon.ico", "/sample", "/sample/other.json", "/vendor/other/x.js", "/viewer"}) {
    EXPECT_EQ(server::parseRoute(path).kind, Route::Kind::kNotFound) << path;
  }
}

TEST(ServeHttpRules, IfNoneMatchComparesWeakly) {
  const std::string etag = "\"abc-12\"";
  EXPECT_TRUE(server::noneMatchHits("\"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("W/\"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("\"x\", \"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("*", etag));
  EXPECT_FALSE(server::noneMatchHits("", etag));
  EXPECT_FALSE(server::noneMatchHits("\"abc-13\"", etag));
  EXPECT_FALSE(server::noneMatchHits("abc-12", etag));
}

TEST(ServeHttpRules, ContentTypes) {
  EXPECT_EQ(server::contentTypeFor("a/b.png"), "image/png");
  EXPECT_EQ(server::contentTypeFor("1.hires.glb"), "model/gltf-binary");
  EXPECT_EQ(server::contentTypeFor("tilejson.json"), "application/json");
  EXPECT_TRUE(startsWith(server::contentTypeFor("index.html"), "text/html"));
  EXPECT_TRUE(startsWith(server::contentTypeFor("three.module.js"), "text/javascript"));
  EXPECT_TRUE(startsWith(server::contentTypeFor("x.mjs"), "text/javascript"));
  EXPECT_EQ(server::contentTypeFor("x.bin"), "application/octet-stream");
}

TEST(ServeHttpRules, OnlyPlausibleHostsBuildUrls) {
  for (const char* host : {"127.0.0.1:8080", "example.org", "[::1]:80", "tiles.example.org:443"}) {
    EXPECT_TRUE(server::isPlausibleHost(host)) << host;
  }
  for (const char* host : {"", "a b", "evil\"host", "x/y", "h:port", "[::1"}) {
    EXPECT_FALSE(server::isPlausibleHost(host)) << host;
  }
}

// --- The bake queue, with injected bakes --------------------------------------

std::shared_ptr<const server::BakedTile> bakedTile() {
  auto tile = std::make_shared<server::BakedTile>();
  (*tile)[io::TileFormat::kPng] = {"png", "\"etag\""};
  return tile;
}

TEST(BakeQueue, RequestsForOneTileShareOneBake) {
  Gate gate;
  std::atomic<int> bakes{0};
  server::BakeQueue queue(2, 8, [&] {
    return [&](const TileId&) {
      ++bakes;
      gate.pass();
      return bakedTile();
    };
  });
  const TileId tile{3, 1, 2};
  std::vector<server::BakeQueue::Ticket> tickets;
  for (int i = 0; i < 5; ++i) tickets.push_back(queue.request(tile, queue.finishedCount()));
  ASSERT_TRUE(gate.waitEntered(1));
  gate.open();
  for (const auto& ticket : tickets) {
    ASSERT_EQ(ticket.kind, server::BakeQueue::Ticket::Kind::kWait);
    EXPECT_EQ(ticket.outcome.get().status, server::BakeOutcome::Status::kBaked);
    EXPECT_EQ(ticket.outcome.get().tile->at(io::TileFormat::kPng).bytes, "png");
  }
  EXPECT_EQ(bakes, 1);
  EXPECT_EQ(queue.counters().started, 1u);
  EXPECT_EQ(queue.counters().written, 1u);
}

TEST(BakeQueue, AFullQueueRefusesAndCountsIt) {
  Gate gate;
  server::BakeQueue queue(1, 1, [&] {
    return [&](const TileId&) {
      gate.pass();
      return bakedTile();
    };
  });
  const auto baking = queue.request({1, 0, 0}, queue.finishedCount());
  ASSERT_TRUE(gate.waitEntered(1));  // the only worker is busy
  const auto waiting = queue.request({1, 0, 1}, queue.finishedCount());
  EXPECT_EQ(waiting.kind, server::BakeQueue::Ticket::Kind::kWait);
  const auto refused = queue.request({1, 1, 0}, queue.finishedCount());
  EXPECT_EQ(refused.kind, server::BakeQueue::Ticket::Kind::kFull);
  // A request for a tile already queued joins it, full queue or not.
  EXPECT_EQ(queue.request({1, 0, 1}, queue.finishedCount()).kind, server::BakeQueue::Ticket::Kind::kWait);
  gate.open();
  EXPECT_EQ(baking.outcome.get().status, server::BakeOutcome::Status::kBaked);
  EXPECT_EQ(waiting.outcome.get().status, server::BakeOutcome::Status::kBaked);
  EXPECT_EQ(queue.counters().rejected, 1u);
}

TEST(BakeQueue, FailedAndEmptyBakesAreReportedAndNotKept) {
  std::atomic<int> calls{0};
  server::BakeQueue queue(1, 4, [&] {
    return [&](const TileId& tile) -> std::shared_ptr<const server::BakedTile> {
      ++calls;
      if (tile.x == 1) throw std::runtime_error("injected failure");
      return nullptr;  // no DEM sample
    };
  });
  const auto failed = queue.request({2, 1, 0}, queue.finishedCount());
  EXPECT_EQ(failed.outcome.get().status, server::BakeOutcome::Status::kFailed);
  EXPECT_EQ(failed.outcome.get().error, "injected failure");
  const auto again = queue.request({2, 1, 0}, queue.finishedCount());
  EXPECT_EQ(again.outcome.get().status, server::BakeOutcome::Status::kFailed);
  EXPECT_EQ(calls, 2) << "a failure is not remembered: the next request bakes again";
  EXPECT_EQ(queue.request({2, 0, 0}, queue.finishedCount()).outcome.get().status,
            server::BakeOutcome::Status::kEmpty);
  EXPECT_EQ(queue.counters().failed, 2u);
  EXPECT_EQ(queue.counters().empty, 1u);
}

TEST(BakeQueue, ABakeFinishingMeanwhileIsNoticed) {
  server::BakeQueue queue(1, 4, [] { return [](const TileId&) { return bakedTile(); }; });
  const std::uint64_t seen = queue.finishedCount();
  queue.request({4, 0, 0}, seen).outcome.wait();
  // Another tile's bake finished since `seen`: the caller must look on disk again.
  EXPECT_EQ(queue.request({4, 0, 0}, seen).kind, server::BakeQueue::Ticket::Kind::kLookAgain);
  EXPECT_EQ(queue.counters().started, 1u);
}

TEST(BakeQueue, StopAbandonsQueuedBakesAndFinishesRunningOnes) {
  Gate gate;
  server::BakeQueue queue(1, 4, [&] {
    return [&](const TileId&) {
      gate.pass();
      return bakedTile();
    };
  });
  const auto running = queue.request({1, 0, 0}, queue.finishedCount());
  ASSERT_TRUE(gate.waitEntered(1));
  const auto queued = queue.request({1, 0, 1}, queue.finishedCount());
  std::thread stopper([&] { queue.stop(); });
  EXPECT_EQ(queued.outcome.get().status, server::BakeOutcome::Status::kAbandoned);
  gate.open();
  EXPECT_EQ(running.outcome.get().status, server::BakeOutcome::Status::kBaked);
  stopper.join();
  EXPECT_EQ(queue.request({1, 1, 1}, queue.finishedCount()).kind, server::BakeQueue::Ticket::Kind::kFull);
}

TEST(BakeQueue, AWorkerThatCannotStartFailsTheConstructor) {
  std::atomic<int> made{0};
  const auto make = [&]() -> server::BakeQueue::Bake {
    if (made++ == 1) throw InputError("no GL context");
    return [](const TileId&) { return bakedTile(); };
  };
  EXPECT_THROW(server::BakeQueue(2, 4, make), InputError);
}

// --- A real server: routes and headers ----------------------------------------

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
}

TEST(ServeHttp, APortInUseIsAnError) {
  const Case c = makeCase();
  ServerThread running(c.config);
  config::ServeConfig second = c.config;
  second.port = running.port();
  EXPECT_THROW(server::Server(second, {}), InputError);
}

TEST(ServeHttp, LayerListPointsAtEachTileJsonFromTheHostHeader) {
  const Case c = makeCase();
  ServerThread running(c.config);
  const auto reply = get(running.port(), "/layers.json", {{"Host", "tiles.example.org:8443"}});
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  EXPECT_EQ(reply->get_header_value("Content-Type"), "application/json");
  const Json body = Json::parse(reply->body);
  ASSERT_EQ(body["layers"].size(), 2u);
  EXPECT_EQ(body["layers"][0]["name"], "live");
  EXPECT_EQ(body["layers"][0]["tilejson"], "http://tiles.example.org:8443/live/tilejson.json");
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

TEST(ServeHttp, HeadSendsHeadersOnly) {
  const Case c = makeCase();
  ServerThread running(c.config);
  // A raw request: a client could hide a body the server wrongly sent.
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
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
  ServerThread running(fakeConfig(dir), [&] {
    std::vector<std::unique_ptr<server::LayerSource>> layers;
    layers.push_back(std::move(layer));
    return layers;
  }());
  std::vector<std::thread> clients;
  std::vector<int> statuses(4);
  for (int i = 0; i < 4; ++i) {
    clients.emplace_back([&, i] { statuses[i] = statusOf(running.port(), "/fake/7/3/5.png"); });
  }
  ASSERT_TRUE(gate.waitEntered(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the others arrive and join
  gate.open();
  for (auto& client : clients) client.join();
  EXPECT_EQ(statuses, std::vector<int>(4, 200));
  EXPECT_EQ(bakes, 1);
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
  ServerThread running(config, [&] {
    std::vector<std::unique_ptr<server::LayerSource>> layers;
    layers.push_back(std::move(layer));
    return layers;
  }());

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
  fs::create_directories(c.tiles / "live");
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
  EXPECT_EQ(filesUnder(c.tiles / "live"), (std::set<std::string>{"13", "tilejson.json"}));
}

TEST(ServeOnDemand, AnInjectedFailureAnswers500AndLeavesNoFile) {
  const fs::path dir = caseDir();
  auto layer = fakeLayer(dir / "tiles", 1, 4, [](const TileId&) -> std::optional<io::TileFiles> {
    throw std::runtime_error("injected failure");
  });
  ServerThread running(fakeConfig(dir), [&] {
    std::vector<std::unique_ptr<server::LayerSource>> layers;
    layers.push_back(std::move(layer));
    return layers;
  }());
  const auto reply = get(running.port(), "/fake/4/2/3.glb");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 500);
  EXPECT_NE(reply->body.find("injected failure"), std::string::npos) << reply->body;
  EXPECT_EQ(filesUnder(dir / "tiles" / "fake"), std::set<std::string>{"tilejson.json"});
}

TEST(ServeOnDemand, ATileWithoutDemSamplesIs404) {
  const fs::path dir = caseDir();
  auto layer = fakeLayer(dir / "tiles", 1, 4, [](const TileId&) { return std::optional<io::TileFiles>(); });
  ServerThread running(fakeConfig(dir), [&] {
    std::vector<std::unique_ptr<server::LayerSource>> layers;
    layers.push_back(std::move(layer));
    return layers;
  }());
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
  ServerThread running(fakeConfig(dir), [&] {
    std::vector<std::unique_ptr<server::LayerSource>> layers;
    layers.push_back(std::move(layer));
    return layers;
  }());
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
            (std::set<std::string>{"tilejson.json", "6/1/1.png", "6/1/1.glb"}));
}

// --- The executable ------------------------------------------------------------

// `terrabake serve` as a child process.
std::vector<std::string> serveArgs(std::vector<std::string> args) {
  args.insert(args.begin(), "serve");
  return args;
}

// Sends `signal` and waits for the exit; the exit code (-1: no clean exit in
// time) and how long it took.
int stopWith(test::ChildProcess& process, int signal, std::chrono::milliseconds* took) {
  const auto start = std::chrono::steady_clock::now();
  process.signal(signal);
  const int code = process.wait(kStopLimit);
  *took = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
  return code;
}

TEST(ServeCli, StartsOnAFreePortAnswersAndStopsOnSigterm) {
  const Case c = makeCase();
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "viewer:\n  dir: viewer\nlayers: [live.yaml]\nhttp:\n  port: 8080\n");
  test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));

  const std::string line = process.firstLine(kWaitLimit);
  const std::string start = "terrabake: serving " + c.tiles.string() + " on http://127.0.0.1:";
  ASSERT_TRUE(startsWith(line, start)) << "stdout: " << line << "\nstderr: " << process.err();
  ASSERT_EQ(line.substr(line.size() - 2), "/\n") << line;
  const int port = std::stoi(line.substr(start.size()));
  ASSERT_GT(port, 0);

  const auto reply = get(port, "/health");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  const auto tile = get(port, tileUrl("live", c.someTile(), "png"));
  ASSERT_TRUE(tile);
  EXPECT_EQ(tile->status, 200);

  std::chrono::milliseconds took{};
  EXPECT_EQ(stopWith(process, SIGTERM, &took), 0) << process.err();
  EXPECT_LT(took, kStopLimit);
  EXPECT_EQ(process.out(), line) << "exactly one line on stdout";
  EXPECT_EQ(process.err().find("error"), std::string::npos) << process.err();
}

TEST(ServeCli, SigintStopsItToo) {
  const Case c = makeCase();
  test::ChildProcess process(serveArgs({"--tiles", c.tiles.string(), "--port", "0"}));
  ASSERT_FALSE(process.firstLine(kWaitLimit).empty()) << process.err();
  std::chrono::milliseconds took{};
  EXPECT_EQ(stopWith(process, SIGINT, &took), 0) << process.err();
}

TEST(ServeCli, BadFlagsAndMissingFoldersAreOneLineErrors) {
  const fs::path dir = caseDir();
  const struct {
    std::vector<std::string> args;
    int exit_code;
    std::string culprit;
  } cases[] = {
      {{"--tiles", dir.string(), "--port", "70000"}, 2, "--port"},
      {{"--tiles", dir.string(), "--bind", "not a host"}, 2, "--bind"},
      {{"--tiles", (dir / "missing").string(), "--port", "0"}, 3, (dir / "missing").string()},
      {{"--config", (dir / "missing.yaml").string()}, 3, "missing.yaml"},
  };
  for (const auto& bad : cases) {
    test::ChildProcess process(serveArgs(bad.args));
    EXPECT_EQ(process.wait(kStopLimit), bad.exit_code) << process.err();
    EXPECT_EQ(std::count(process.err().begin(), process.err().end(), '\n'), 1) << process.err();
    EXPECT_NE(process.err().find(bad.culprit), std::string::npos) << process.err();
    EXPECT_EQ(process.out(), "");
  }
}

}  // namespace
}  // namespace terrabake

#pragma once
// Helpers for tests of `terrabake serve` (server_*_test, bake_queue_test,
// mbtiles_test): a server on a thread of its own, a test case's tiles and
// viewer folders, HTTP requests with a deadline, a gate that holds a bake, and
// on-demand layers whose bakes the test injects. Needs terrabake_server.
#include <gtest/gtest.h>

#include <httplib.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "config/tile_job.hpp"
#include "core/types.hpp"
#include "layer_check.hpp"
#include "pipeline/tile_job_runner.hpp"
#include "server/layer_catalog.hpp"
#include "server/on_demand_layer.hpp"
#include "server/served_folder.hpp"
#include "server/server.hpp"
#include "test_helpers.hpp"

namespace terrabake::test {

// Long enough for a bake on a loaded 2-core machine; a hang fails instead of blocking the run.
constexpr auto kWaitLimit = std::chrono::seconds(60);
// What the fixture's secret file holds: no response may ever contain it.
constexpr const char* kSecret = "terrabake-server-test-secret";

// Small and fast: 64-texel tiles, the CPU baker, zooms where the DEM spans a few tiles.
constexpr const char* kJobBody = "tiling:\n  zoom: [11, 13]\n  tile_size: 64\n";

inline config::TileJob smallJob(const std::filesystem::path& tiles, const std::string& layer) {
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
  std::filesystem::path dir;
  std::filesystem::path tiles;
  std::filesystem::path viewer;
  std::filesystem::path live_job;
  config::ServeConfig config;

  // A tile that exists in "static": the first png at zoom 13.
  TileId someTile() const {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(tiles / "static" / "13")) {
      if (entry.path().extension() == ".png" && entry.path().stem().extension().empty()) {
        return {13, std::stoi(entry.path().parent_path().filename().string()), std::stoi(entry.path().stem().string())};
      }
    }
    throw std::runtime_error("no zoom-13 tile in the static layer");
  }
};

inline std::string tileUrl(const std::string& layer, const TileId& tile, const std::string& extension) {
  return "/" + layer + "/" + tile.str() + "." + extension;
}

inline Case makeCase(const std::string& live_backend = "cpu") {
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
  std::filesystem::create_symlink(c.dir / "secret.txt", c.viewer / "escape.js");  // points out of the viewer
  std::filesystem::create_symlink("viewer.js", c.viewer / "alias.js");             // stays inside: fine

  c.live_job = c.dir / "live.yaml";
  writeText(c.live_job, "dem: " + smallDem().string() + "\noutput:\n  layer: live\n" + kJobBody +
                            "bake:\n  backend: " + live_backend + "\n  workers: 2\n");

  c.config.tiles_dir = c.tiles.string();
  c.config.layer_jobs = {c.live_job.string()};
  c.config.port = 0;
  c.config.viewer_dir = c.viewer.string();
  return c;
}

// A serve config of the layers in `tiles_dir`, on any free port, with no viewer.
inline config::ServeConfig servingLayersIn(const std::filesystem::path& tiles_dir) {
  config::ServeConfig config;
  config.tiles_dir = tiles_dir.string();
  config.port = 0;
  config.viewer_dir = (tiles_dir / "no_viewer").string();
  return config;
}

// A server's layer list holding just `layer`.
inline std::vector<std::unique_ptr<server::LayerSource>> onlyLayer(std::unique_ptr<server::LayerSource> layer) {
  std::vector<std::unique_ptr<server::LayerSource>> layers;
  layers.push_back(std::move(layer));
  return layers;
}

// A server on an ephemeral port, run on a thread of its own; the destructor is
// the scope guard that stops and joins it, whatever the test did.
class ServerThread {
 public:
  ServerThread(const config::ServeConfig& config, std::vector<std::unique_ptr<server::LayerSource>> layers,
               server::LayerSet::LookForNew look_for_new = {})
      : m_server(config, std::move(layers), std::move(look_for_new)), m_thread([this] { m_server.run(); }) {}
  // As `terrabake serve` serves the config: its layers, and those found later.
  explicit ServerThread(const config::ServeConfig& config)
      : ServerThread(config, server::openLayers(config), server::lookForStoredLayers(config.tiles_dir)) {}
  ~ServerThread() {
    m_server.stop();
    m_thread.join();
  }
  ServerThread(const ServerThread&) = delete;
  ServerThread& operator=(const ServerThread&) = delete;

  server::Server& server() { return m_server; }
  int port() const { return m_server.port(); }

 private:
  server::Server m_server;
  std::thread m_thread;
};

// GET with a read timeout of kWaitLimit: a request the server never answers fails.
inline httplib::Result get(int port, const std::string& path, const httplib::Headers& headers = {}) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(std::chrono::duration_cast<std::chrono::seconds>(kWaitLimit).count());
  return client.Get(path.c_str(), headers);
}

inline int statusOf(int port, const std::string& path) {
  const auto reply = get(port, path);
  return reply ? reply->status : -1;
}

inline nlohmann::json health(int port) {
  const auto reply = get(port, "/health");
  if (!reply || reply->status != 200) throw std::runtime_error("GET /health failed");
  return nlohmann::json::parse(reply->body);
}

// A gate a test holds a bake at: the bake enters and waits until the test
// opens it. A bake held past kWaitLimit goes on by itself (the test that
// forgot to open, or failed before it could, has failed already), so a
// worker never blocks the server's shutdown for ever.
class Gate {
 public:
  void pass() {
    std::unique_lock<std::mutex> lock(m_mutex);
    ++m_entered;
    m_changed.notify_all();
    m_changed.wait_for(lock, kWaitLimit, [this] { return m_open; });
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

// How many of this process's open files were removed and named something
// starting with `prefix` (an absolute path): /proc/self/fd links to a
// removed file end in " (deleted)".
inline int removedFilesHeldOpen(const std::string& prefix) {
  int held = 0;
  std::error_code ec;
  for (const auto& fd : std::filesystem::directory_iterator("/proc/self/fd", ec)) {
    const std::string target = std::filesystem::read_symlink(fd.path(), ec).string();
    const std::string removed = " (deleted)";
    if (!ec && target.rfind(prefix, 0) == 0 && target.size() >= removed.size() &&
        target.compare(target.size() - removed.size(), removed.size(), removed) == 0) {
      ++held;
    }
  }
  return held;
}

// That `action`, run while every file descriptor is taken, throws an
// UnreadableFile saying a later try may work, its message holding `names`.
// Looked at once the descriptors are back: UBSan checks a virtual call
// through a pipe, for which none would be left.
inline void expectBusyWithAllFilesOpen(const std::function<void()>& action, const std::string& names = "") {
  std::exception_ptr error;
  {
    const AllFilesOpen taken;
    try {
      action();
    } catch (...) {
      error = std::current_exception();
    }
  }
  ASSERT_TRUE(error) << "nothing thrown with no file descriptor left";
  try {
    std::rethrow_exception(error);
  } catch (const server::UnreadableFile& e) {
    EXPECT_TRUE(e.temporary) << e.what();
    EXPECT_NE(std::string(e.what()).find(names), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not UnreadableFile: " << e.what();
  }
}

// Polls `condition` for up to kWaitLimit.
inline bool waitFor(const std::function<bool()>& condition) { return waitUntil(condition, kWaitLimit); }

// An on-demand layer whose tiles come from `make` instead of a DEM, over every zoom.
// The job record of fakeLayer's folder: tiles already in it must sit beside
// it, as those of an earlier run of the layer do.
inline constexpr const char* kFakeJobRecord = "scheme: fake\n";

inline std::unique_ptr<server::OnDemandLayer> fakeLayer(const std::filesystem::path& tiles, int workers,
                                                        std::size_t queue_size, server::OnDemandLayer::MakeTile make) {
  server::OnDemandLayer::Settings settings{"fake",
                                           tiles / "fake",
                                           R"({"tilejson": "3.0.0", "tiles": ["./{z}/{x}/{y}.png"]})",
                                           kFakeJobRecord,
                                           server::TileCoverage(0, 24),
                                           false,
                                           workers,
                                           queue_size,
                                           false,
                                           "",
                                           nullptr};
  return std::make_unique<server::OnDemandLayer>(std::move(settings), [make] { return make; });
}

// The smallest valid glTF binary (the validator checks every .glb the tests write).
inline std::vector<std::uint8_t> minimalGlb() {
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

inline io::TileFiles fakeFiles() {
  io::TileFiles files;
  const std::string png = "\x89PNG fake";
  files.png.assign(png.begin(), png.end());
  files.glb = minimalGlb();
  return files;
}

inline config::ServeConfig fakeConfig(const std::filesystem::path& dir) {
  config::ServeConfig config;
  config.tiles_dir = (dir / "tiles").string();
  std::filesystem::create_directories(config.tiles_dir);
  config.port = 0;
  config.viewer_dir = (dir / "no_viewer").string();
  return config;
}

}  // namespace terrabake::test

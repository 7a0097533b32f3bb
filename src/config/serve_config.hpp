#pragma once
// Settings of `terrabake serve`: every key of its YAML file, with its default.
// config/README.md documents each one ("serve" section); keep the two in step.
#include <string>
#include <vector>

#include "config/key_info.hpp"

namespace terrabake::config {

// The viewer folder of the source tree, compiled in (TERRABAKE_VIEWER_DIR).
std::string defaultViewerDir();

struct ServeConfig {
  std::string tiles_dir = "tiles";           // tiles: the folder of layers (server/layer_catalog.hpp)
  std::vector<std::string> layer_jobs;       // layers: tile-job files baked on demand
  std::string bind = "127.0.0.1";            // http.bind
  int port = 8080;                           // http.port: 0 = any free port
  int threads = 0;                           // http.threads: threads answering requests; 0 = one per core
  int max_connections = 1024;                // http.max_connections: open at once; more are refused
  int read_timeout_s = 10;                   // http.read_timeout_s: to send a request head, to take an answer
  int idle_timeout_s = 5;                    // http.idle_timeout_s: a kept connection with no request
  int max_header_bytes = 16384;              // http.max_header_bytes: request line and headers
  std::string public_url;                    // server.public_url: base of tilejson URLs; "" = the listen address
  int tile_max_age_s = 3600;                 // http.tile_max_age_s: Cache-Control max-age of tiles
  int cache_mib = 64;                        // http.cache_mib: tiles kept in memory, MiB; 0 = none
  std::string viewer_dir = defaultViewerDir();  // viewer.dir
  int queue_size = 64;                       // bake.queue_size: bakes waiting, per layer
  int retry_after_s = 1;                     // bake.retry_after_s: Retry-After of a 503
};

// Reads a YAML file; relative paths in it resolve against the file's folder.
// Errors as loadTileJob(): UsageError "<file>:<line>: <key>: <problem>",
// InputError if the file cannot be read.
ServeConfig loadServeConfig(const std::string& yaml_path);
// As loadServeConfig, for YAML text already read; `yaml_path` names it.
ServeConfig parseServeConfig(const std::string& yaml_text, const std::string& yaml_path);

// Sets one key ("http.port", "tiles", ...) from command-line text, validated
// exactly like the file (several values: a list); `origin` names the flag in
// messages.
void applyOverride(ServeConfig& config, const std::string& key, const std::vector<std::string>& values,
                   const std::string& origin);

// Throws UsageError "<origin>: <key>: <problem>".
void validate(const ServeConfig& config, const std::string& origin);

// Every key, in the order of config/serve.yaml.
std::vector<KeyInfo> listServeKeys();

}  // namespace terrabake::config

#include "config/serve_config.hpp"

#include <regex>
#include <string>

#include "config/key_table.hpp"

namespace terrabake::config {
namespace {

namespace kt = key_table;
using kt::number;
using kt::text;

constexpr int kMaxPort = 65535;
constexpr int kYearS = 365 * 24 * 3600;  // the longest max-age caches are asked to honour
constexpr int kMaxCacheMib = 65536;      // 64 GiB of tiles in memory

// A base URL: http:// or https://, a host, an optional port and path, no query; "" = none.
std::string publicUrlProblem(const std::string& url) {
  static const std::regex kUrl(
      R"(https?://(?:[A-Za-z0-9.-]+|\[[0-9A-Fa-f:.]+\])(?::[0-9]{1,5})?(?:/[A-Za-z0-9._~!$&'()*+,;=:@%/-]*)?)");
  if (url.empty() || std::regex_match(url, kUrl)) return {};
  return "must be an http:// or https:// URL: host, optional port and path, no query, got '" + url + "'";
}

std::string writeUrl(const std::string& url) { return url.empty() ? "\"\"" : url; }

// The one table of keys of a serve file; config_test checks config/README.md against it.
const kt::KeyTable<ServeConfig>& table() {
  static const kt::KeyTable<ServeConfig> kTable({
      {"tiles", "--tiles", "path", "folder whose subfolders are layers (each with a tilejson.json)",
       text(&ServeConfig::tiles_dir, kt::parsePath, kt::pathProblem, kt::writeText)},
      {"layers", "", "path or list of paths",
       "tile-job files whose layers are baked on demand, into <tiles>/<output.layer>",
       text(&ServeConfig::layer_jobs, kt::parseOptionalPaths, kt::pathsProblem, kt::joinPaths)},
      {"http.bind", "--bind", "host", "address to listen on: an IP address or a host name",
       text(&ServeConfig::bind, kt::parseWord, kt::hostProblem, kt::writeText)},
      {"http.port", "--port", "integer", "TCP port, 0 = any free port, 0..65535", number(&ServeConfig::port, 0, kMaxPort)},
      {"http.threads", "", "integer",
       "threads answering requests (a request waiting for a bake holds none), 0 = one per core, 0..256",
       number(&ServeConfig::threads, 0, 256)},
      {"http.max_connections", "", "integer",
       "connections open at once; beyond that a new one gets 503 and is closed, 16..100000",
       number(&ServeConfig::max_connections, 16, 100000)},
      {"http.read_timeout_s", "", "integer",
       "seconds a client has to send a request's line and headers, and to take an answer (a file's, each 64 KiB "
       "of it), 1..3600",
       number(&ServeConfig::read_timeout_s, 1, 3600)},
      {"http.idle_timeout_s", "", "integer", "seconds a kept-alive connection may wait for its next request, 1..3600",
       number(&ServeConfig::idle_timeout_s, 1, 3600)},
      {"http.max_header_bytes", "", "integer",
       "bytes of a request's line and headers; more get 431 (414 for a line alone), 1024..1048576",
       number(&ServeConfig::max_header_bytes, 1024, 1048576)},
      {"http.tile_max_age_s", "", "integer", "seconds browsers may keep a tile without asking again, 0..31536000",
       number(&ServeConfig::tile_max_age_s, 0, kYearS)},
      {"http.cache_mib", "--cache-mib", "integer",
       "MiB of tiles kept in memory, the most recently asked for; 0 = none, 0..65536",
       number(&ServeConfig::cache_mib, 0, kMaxCacheMib)},
      {"server.public_url", "--public-url", "URL",
       "base of the tile URLs in tilejson and layers.json (https://tiles.example.org/); \"\" = the address the "
       "client connected to",
       text(&ServeConfig::public_url, kt::parseWord, publicUrlProblem, writeUrl)},
      {"viewer.dir", "", "path", "folder of the web viewer: index.html, viewer.js, node_modules/three",
       text(&ServeConfig::viewer_dir, kt::parsePath, kt::pathProblem, kt::writeText)},
      {"bake.queue_size", "", "integer", "on-demand bakes waiting per layer; a request for another missing tile then gets 503 at once, 1..65536",
       number(&ServeConfig::queue_size, 1, 65536)},
      {"bake.retry_after_s", "", "integer", "Retry-After of a 503 for a full bake queue, seconds, 1..3600",
       number(&ServeConfig::retry_after_s, 1, 3600)},
  });
  return kTable;
}

}  // namespace

std::string defaultViewerDir() { return TERRABAKE_VIEWER_DIR; }

ServeConfig loadServeConfig(const std::string& yaml_path) { return table().load(yaml_path); }

ServeConfig parseServeConfig(const std::string& yaml_text, const std::string& yaml_path) {
  return table().loadText(yaml_text, yaml_path);
}

void applyOverride(ServeConfig& config, const std::string& key, const std::vector<std::string>& values,
                   const std::string& origin) {
  table().applyOverride(config, key, values, origin);
}

void validate(const ServeConfig& config, const std::string& origin) { table().validate(config, origin); }

std::vector<KeyInfo> listServeKeys() { return table().list(); }

}  // namespace terrabake::config

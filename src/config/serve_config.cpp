#include "config/serve_config.hpp"

#include "config/key_table.hpp"

namespace terrabake::config {
namespace {

namespace kt = key_table;
using kt::number;
using kt::text;

constexpr int kMaxPort = 65535;
constexpr int kYearS = 365 * 24 * 3600;  // the longest max-age caches are asked to honour

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
      {"http.threads", "", "integer", "requests handled at once, 1..256", number(&ServeConfig::threads, 1, 256)},
      {"http.tile_max_age_s", "", "integer", "seconds browsers may keep a tile without asking again, 0..31536000",
       number(&ServeConfig::tile_max_age_s, 0, kYearS)},
      {"viewer.dir", "", "path", "folder of the web viewer: index.html, viewer.js, node_modules/three",
       text(&ServeConfig::viewer_dir, kt::parsePath, kt::pathProblem, kt::writeText)},
      {"bake.queue_size", "", "integer", "on-demand bakes waiting per layer before requests get 503, 1..65536",
       number(&ServeConfig::queue_size, 1, 65536)},
      {"bake.retry_after_s", "", "integer", "Retry-After of a 503 for a full bake queue, seconds, 1..3600",
       number(&ServeConfig::retry_after_s, 1, 3600)},
  });
  return kTable;
}

}  // namespace

std::string defaultViewerDir() { return TERRABAKE_VIEWER_DIR; }

ServeConfig loadServeConfig(const std::string& yaml_path) { return table().load(yaml_path); }

void applyOverride(ServeConfig& config, const std::string& key, const std::string& value,
                   const std::string& origin) {
  table().applyOverride(config, key, value, origin);
}

void validate(const ServeConfig& config, const std::string& origin) { table().validate(config, origin); }

std::vector<KeyInfo> listServeKeys() { return table().list(); }

}  // namespace terrabake::config

#include "config/serve_config.hpp"

#include "config/key_table.hpp"

namespace terrabake::config {
namespace {

using IntField = key_table::IntField<ServeConfig>;
using HostField = key_table::HostField<ServeConfig>;
using PathField = key_table::PathField<ServeConfig>;
using PathListField = key_table::PathListField<ServeConfig>;

constexpr int kMaxPort = 65535;
constexpr int kYearS = 365 * 24 * 3600;  // the longest max-age caches are asked to honour

// Keep config/README.md in step (server_test checks every key is there).
const key_table::KeyTable<ServeConfig>& table() {
  static const key_table::KeyTable<ServeConfig> kTable({
      {"tiles", "path", "folder whose subfolders are layers (each with a tilejson.json)",
       PathField{&ServeConfig::tiles_dir}},
      {"layers", "path or list of paths",
       "tile-job files whose layers are baked on demand, into <tiles>/<output.layer>",
       PathListField{&ServeConfig::layer_jobs, false}},
      {"http.bind", "host", "address to listen on: an IP address or a host name",
       HostField{&ServeConfig::bind}},
      {"http.port", "integer", "TCP port, 0 = any free port, 0..65535",
       IntField{&ServeConfig::port, 0, kMaxPort}},
      {"http.threads", "integer", "requests handled at once, 1..256",
       IntField{&ServeConfig::threads, 1, 256}},
      {"http.tile_max_age_s", "integer", "seconds browsers may keep a tile without asking again, 0..31536000",
       IntField{&ServeConfig::tile_max_age_s, 0, kYearS}},
      {"viewer.dir", "path", "folder of the web viewer: index.html, viewer.js, node_modules/three",
       PathField{&ServeConfig::viewer_dir}},
      {"bake.queue_size", "integer", "on-demand bakes waiting per layer before requests get 503, 1..65536",
       IntField{&ServeConfig::queue_size, 1, 65536}},
      {"bake.retry_after_s", "integer", "Retry-After of a 503 for a full bake queue, seconds, 1..3600",
       IntField{&ServeConfig::retry_after_s, 1, 3600}},
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

#pragma once
// The layers a serve config names: the on-demand layers of its tile jobs,
// every other folder under `tiles` that holds a tilejson.json, and every
// `<name>.mbtiles` file there whose name no folder layer took.
#include <memory>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

// Throws UsageError for a bad tile job or a layer name the server's routes
// take, InputError for an unreadable tiles folder or DEM, or no GL context.
// A folder whose tilejson.json cannot be used, or an MBTiles file that is
// not terrabake's or not finished, is skipped with a warning.
std::vector<std::unique_ptr<LayerSource>> openLayers(const config::ServeConfig& config);

}  // namespace terrabake::server

#pragma once
// The layers a serve config names: the on-demand layers of its tile jobs,
// and every other folder under `tiles` that holds a tilejson.json.
#include <memory>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

// Throws UsageError for a bad tile job or a layer name the server's routes
// take, InputError for an unreadable tiles folder or DEM, or no GL context.
// A folder whose tilejson.json cannot be used is skipped with a warning.
std::vector<std::unique_ptr<LayerSource>> openLayers(const config::ServeConfig& config);

}  // namespace terrabake::server

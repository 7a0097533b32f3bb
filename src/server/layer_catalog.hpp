#pragma once
// The layers a serve config names: the on-demand layers of its tile jobs,
// every other folder under `tiles` that holds a tilejson.json, and every
// `<name>.mbtiles` and `<name>.pmtiles` file there whose name no layer took.
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_set.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

// Throws UsageError for a bad tile job or a layer name the server's routes
// take, InputError for an unreadable tiles folder or DEM, or no GL context.
// A folder whose tilejson.json cannot be used, or an MBTiles file that is
// not terrabake's or not finished, is skipped with a warning.
std::vector<std::unique_ptr<LayerSource>> openLayers(const config::ServeConfig& config);

// The folder, MBTiles and PMTiles layers in `tiles_dir` whose names are not
// in `known`: openLayers' own look, and a later one for layers a batch run
// finished while the server runs. Skipped folders and files are warned
// about on the `first_look` only. Throws InputError for an unreadable folder.
std::vector<std::unique_ptr<LayerSource>> openStoredLayers(const std::string& tiles_dir,
                                                           const std::set<std::string>& known, bool first_look);

// The later looks (openStoredLayers) into `tiles_dir`, for a Server.
LayerSet::LookForNew lookForStoredLayers(const std::string& tiles_dir);

}  // namespace terrabake::server

#pragma once
// A layer written into one MBTiles file instead of a folder
// (config/README.md, "MBTiles").
#include <memory>
#include <string>

#include "pipeline/tile_sink.hpp"

namespace terrabake::pipeline {

// <dir>/<layer>.mbtiles: images in `tiles`, meshes in `meshes` (and
// `high_res_meshes`), the job fingerprint in metadata row `terrabake_job`,
// the tilejson in `json`. `tms_rows`: the scheme's y counts from the south
// already (geodetic) and is stored as it is; otherwise rows are flipped.
// Throws InputError naming the file when it cannot be created, or exists and
// is not an MBTiles file terrabake wrote.
std::unique_ptr<TileSink> openMbtilesSink(const std::string& path, bool high_res_mesh, bool tms_rows);

}  // namespace terrabake::pipeline

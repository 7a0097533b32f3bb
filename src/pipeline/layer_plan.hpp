#pragma once
// What a run of a tile job decides once, before any tile: the scheme and the
// area it covers, how each zoom reads the DEM, the backdrop, the settings of
// every tile and the layer's tilejson. The batch runner and the tile server
// both start from it, so a tile baked on demand has the bytes a batch run
// writes.
#include <map>
#include <memory>
#include <string>

#include "bake/encode.hpp"
#include "config/tile_job.hpp"
#include "core/types.hpp"
#include "dem/backdrop.hpp"
#include "dem/dem_source.hpp"
#include "gl/baker_factory.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::pipeline {

struct TileSettings {
  int tile_size = 256;
  int low_poly_grid = 17;
  int bits = 8;
  bake::Green green = bake::Green::kUp;
  bool high_res_mesh = false;  // also make the high-res display mesh
  bool alpha = false;          // RGBA: alpha 0 on texels the DEM had no sample for
  double height_scale = 1;     // metres of output height per DEM unit (z_scale * exaggeration)
  int max_fill_px = 64;        // holes are filled this far in; beyond, the backdrop
};

struct LayerPlan {
  std::shared_ptr<const tiling::Scheme> scheme;
  int min_zoom = 0;  // the job's zooms, "auto" resolved
  int max_zoom = 0;
  Extent area;  // what the run covers in the scheme's CRS: the DEM's extent, within tiling.bbox
  std::map<int, dem::ReadPlan> read_plans;  // per zoom of the job
  std::shared_ptr<const dem::Backdrop> backdrop;
  TileSettings settings;
  gl::Backend backend = gl::Backend::kAuto;
  std::string tilejson;  // tile URLs relative to the layer folder
};

// Throws UsageError for zooms the scheme does not have or a bbox beside the
// DEM, InputError for a DEM that cannot be read.
LayerPlan planLayer(const config::TileJob& job, const dem::DemSource& dem);

}  // namespace terrabake::pipeline

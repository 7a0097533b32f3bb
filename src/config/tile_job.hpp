#pragma once
// Settings of a `terrabake tile` run: every key of the YAML file, with its
// default. The key table in tile_job.cpp declares each key once (flag, type,
// range, doc); config/README.md is checked against it.
#include <string>
#include <vector>

#include "config/key_info.hpp"
#include "core/choices.hpp"

namespace terrabake::config {

struct TileJob {
  std::vector<std::string> dems;                  // dem: one path or a list (required)
  std::string output_dir = "tiles";               // output.dir
  std::string layer = "default";                  // output.layer
  OutputFormat format = OutputFormat::kFiles;     // output.format
  int bits = 8;                                   // output.bits: 8 or 16
  Green green = Green::kUp;                       // output.green
  bool high_res_mesh = false;                     // output.high_res_mesh: also write {y}.hires.glb
  bool alpha = false;                             // output.alpha: RGBA, alpha 0 where the DEM had no sample
  bool tileset = false;                           // output.tileset: also write tileset.json (3D Tiles)
  Elevation elevation = Elevation::kNone;         // output.elevation: {y}.elevation.png beside each normal map
  SchemeKind scheme = SchemeKind::kWebMercator;   // tiling.scheme
  int min_zoom = 0;                               // tiling.zoom: N, [min, max], "min-max", max may be "auto"
  int max_zoom = 0;                               // unused when max_zoom_auto
  bool max_zoom_auto = false;                     // the deepest zoom the DEM's resolution supports
  bool zoom_set = false;                          // tiling.zoom given at all (it is required)
  std::vector<double> bbox;                       // tiling.bbox: west, south, east, north (degrees); empty: all
  int tile_size = 256;                            // tiling.tile_size: texels a side
  int band = 1;                                   // heights.band: the raster band that holds heights
  double z_scale = 1;                             // heights.z_scale: metres per DEM height unit
  double exaggeration = 1;                        // heights.exaggeration: vertical exaggeration
  int max_fill_px = 64;                           // nodata.max_fill_px: texels filled from a hole's edge
  NodataSurface nodata_surface = NodataSurface::kContinue;  // nodata.surface
  LowPolyMesh low_poly_mesh = LowPolyMesh::kAdaptive;  // low_poly.mesh
  double max_error_m = 0;                         // low_poly.max_error_m: 0 = from max_error_texels per zoom
  double max_error_texels = 1;                    // low_poly.max_error_texels: bound per zoom, in texels
  int low_poly_grid = 17;                         // low_poly.grid: vertices a side
  Skirts skirts = Skirts::kAuto;                  // low_poly.skirts
  Backend backend = Backend::kAuto;               // bake.backend
  int workers = 0;                                // bake.workers: 0 = one per usable core
};

// Reads a YAML file. Relative paths in it resolve against the file's folder.
// Throws UsageError "<file>:<line>: <key>: <problem>" for unknown keys,
// wrong types, out-of-range values and YAML syntax errors, UsageError
// "<file>: ..." for an empty file, InputError if the file cannot be read.
// Required keys may be left to overrides: call validate() once they are applied.
TileJob loadTileJob(const std::string& yaml_path);
// As loadTileJob, for YAML text already read (loadTileJob reads the file and
// calls this): `yaml_path` names it in messages and relative paths resolve
// against its folder.
TileJob parseTileJob(const std::string& yaml_text, const std::string& yaml_path);

// Sets one key ("output.layer", "tiling.zoom", ...) from command-line text,
// validated exactly like the file: one value, or several for a list (a flag
// given more than once). `origin` names the flag in messages. Relative paths
// resolve against the working directory.
void applyOverride(TileJob& job, const std::string& key, const std::vector<std::string>& values,
                   const std::string& origin);

// The keys that decide what a layer's tiles hold, as "key: value" lines: a
// layer records it, and resuming with a job that describes differently is
// refused. output.dir and bake.workers are left out: they do not change a
// tile's bytes.
std::string layerFingerprint(const TileJob& job);

// What tells two fingerprints apart, for the refusal: "key: A there, B here"
// per key whose value differs ("none" where one has no such key), joined by
// "; ", the first three and a count of the rest. Empty when they hold the
// same keys and values.
std::string fingerprintDifferences(const std::string& recorded, const std::string& wanted);

// Whether a layer whose job is `recorded` grows into `wanted`'s: the same
// settings but for tiling.zoom and tiling.bbox, which take in the recorded
// ones (zooms holding the recorded zooms, a deep end of auto only after
// auto, whose zoom is the DEM's; a box holding the recorded box, or none).
// A tile's bytes depend on neither, so the tiles the layer holds are the
// grown job's too. Keys the job's low-poly mesh does not read may differ
// as well (low_poly.grid for adaptive meshes, the error bounds for grids).
bool growsLayer(const std::string& recorded, const std::string& wanted);

// A layer that another job, whose fingerprint is `recorded`, made, claimed
// for the job `wanted`: taken when `wanted` grows it, which the log says
// (`grown_note` added), and then its tiles are this job's (returns true);
// taken with `force` (returns false); refused otherwise with a UsageError
// naming what differs and `remedy`. `layer` names the layer in both
// messages ("output: layer 'tiles/alps'").
bool claimLayerOfAnotherJob(const std::string& layer, const std::string& recorded, const std::string& wanted,
                            bool force, const std::string& remedy, const std::string& grown_note = "");

// Checks the settings as a whole (required keys present, zoom order, ...).
// Throws UsageError "<origin>: <key>: <problem>".
void validate(const TileJob& job, const std::string& origin);

// Every key, in the order of config/sample.yaml.
std::vector<KeyInfo> listKeys();

}  // namespace terrabake::config

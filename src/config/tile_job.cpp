#include "config/tile_job.hpp"

#include "config/key_table.hpp"

namespace terrabake::config {
namespace {

using IntField = key_table::IntField<TileJob>;
using DoubleField = key_table::DoubleField<TileJob>;
using BoolField = key_table::BoolField<TileJob>;
using WordField = key_table::WordField<TileJob>;
using NameField = key_table::NameField<TileJob>;
using PathField = key_table::PathField<TileJob>;
using PathListField = key_table::PathListField<TileJob>;
using ZoomField = key_table::ZoomField<TileJob>;
using BoxField = key_table::BoxField<TileJob>;

// The one table of keys: files, overrides, validate() and listKeys() all read it.
// Keep config/README.md in step (config_test checks every key is there).
const key_table::KeyTable<TileJob>& table() {
  static const key_table::KeyTable<TileJob> kTable({
      {"dem", "path or list of paths", "DEM file(s) to tile, any format GDAL reads",
       PathListField{&TileJob::dems}},
      {"output.dir", "path", "folder that holds the layers", PathField{&TileJob::output_dir}},
      {"output.layer", "folder name",
       "layer folder under output.dir: letters, digits, '.', '_' and '-'",
       NameField{&TileJob::layer}},
      {"output.format", "string",
       "how the layer is stored: files (a folder of {z}/{x}/{y} files) or mbtiles (one SQLite file)",
       WordField{&TileJob::format, {"files", "mbtiles"}}},
      {"output.bits", "integer", "bits per channel of the normal-map PNGs: 8 or 16",
       IntField{&TileJob::bits, 8, 16, {8, 16}}},
      {"output.green", "string",
       "where +Y of tangent space points: up (OpenGL, glTF) or down (DirectX)",
       WordField{&TileJob::green, {"up", "down"}}},
      {"output.high_res_mesh", "boolean",
       "also write {y}.hires.glb, the full-resolution surface, for viewers that compare",
       BoolField{&TileJob::high_res_mesh}},
      {"output.alpha", "boolean",
       "RGBA normal maps: alpha 0 where the DEM has no valid sample (holes, outside it), else opaque",
       BoolField{&TileJob::alpha}},
      {"tiling.scheme", "string",
       "tile grid: webmercator (EPSG:3857, XYZ), geodetic (EPSG:4326, TMS) or native "
       "(the DEM's own grid)",
       WordField{&TileJob::scheme, {"webmercator", "geodetic", "native"}}},
      {"tiling.zoom", "integer, [min, max], \"min-max\" or auto",
       "zoom levels to make, 0..24; auto as max: the deepest zoom whose texels are no smaller than "
       "the DEM's pixels (auto alone: 0-auto)",
       ZoomField{&TileJob::min_zoom, &TileJob::max_zoom, &TileJob::max_zoom_auto, &TileJob::zoom_set}},
      {"tiling.bbox", "[west, south, east, north]",
       "only tiles that intersect this box, degrees of longitude and latitude (WGS84)",
       BoxField{&TileJob::bbox}},
      {"tiling.tile_size", "integer", "texels a side of each normal map, 16..4096",
       IntField{&TileJob::tile_size, 16, 4096}},
      {"heights.z_scale", "number",
       "metres per DEM height unit (0.3048 for feet), above 0 and at most 1000",
       DoubleField{&TileJob::z_scale, 0, 1000, true}},
      {"heights.exaggeration", "number",
       "vertical exaggeration of the normal maps and meshes, above 0 and at most 100",
       DoubleField{&TileJob::exaggeration, 0, 100, true}},
      {"nodata.max_fill_px", "integer",
       "holes are filled this many texels in from their edge, the rest takes the coarse backdrop; "
       "0..512",
       IntField{&TileJob::max_fill_px, 0, 512}},
      {"low_poly.grid", "integer", "vertices a side of each tile's low-poly mesh, 2..257",
       IntField{&TileJob::low_poly_grid, 2, 257}},
      {"bake.backend", "string",
       "how normals are baked: auto (terrabake picks), osmesa or egl (GL), cpu (reference)",
       WordField{&TileJob::backend, {"auto", "osmesa", "egl", "cpu"}}},
      {"bake.workers", "integer", "tiles baked in parallel, 0 = one per core, 0..256",
       IntField{&TileJob::workers, 0, 256}},
  });
  return kTable;
}

}  // namespace

TileJob loadTileJob(const std::string& yaml_path) { return table().load(yaml_path); }

std::string layerFingerprint(const TileJob& job) { return table().describe(job, {"output.dir", "bake.workers"}); }

void applyOverride(TileJob& job, const std::string& key, const std::string& value,
                   const std::string& origin) {
  table().applyOverride(job, key, value, origin);
}

void validate(const TileJob& job, const std::string& origin) { table().validate(job, origin); }

std::vector<KeyInfo> listKeys() { return table().list(); }

}  // namespace terrabake::config

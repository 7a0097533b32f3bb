#pragma once
// Writing a layer's files: normal-map images, low-poly meshes, tilejson.
// Every file appears atomically under its final name (temp file + rename).
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/choices.hpp"
#include "core/types.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::io {

// Writes bytes to path through a temporary file in the same folder and a
// rename, creating missing parent folders. Throws InputError naming the path.
void writeFileAtomically(const std::string& path, const std::vector<std::uint8_t>& bytes);
// The same for a text file (JSON documents, tilejson).
void writeTextFileAtomically(const std::string& path, const std::string& text);

// As writeFileAtomically, but only when `path` does not exist yet: of several
// writers racing for one path exactly one creates it (a hard link, which
// fails on an existing name). Returns false, writing nothing, when the path
// exists.
bool writeFileExclusively(const std::string& path, const std::vector<std::uint8_t>& bytes);

// A new, empty, hidden temporary file in the folder of `path` (created when
// missing), named as writeFileAtomically names its own: the writer's host and
// process in the name let a later run tell an abandoned one from a live one.
// Its mode is what open() would give `path`. The caller closes `fd` and
// renames or removes the file. Throws InputError naming `path`.
struct TempFile {
  std::string path;
  int fd = -1;
};
TempFile createTempFile(const std::string& path);

// True for a temporary file of writeFileAtomically whose writer is gone: a
// process of this host that no longer runs, or any writer over a minute ago.
// Only names of the form writeFileAtomically gives count: a user's hidden
// file that holds ".tmp-" is none.
bool isAbandonedTempFile(const std::string& path);

// PNG bytes of an RGB or RGBA image whose samples are 8-bit (0..255) or
// 16-bit (0..65535) values, every row Paeth-filtered and deflated by
// zlibCompress (io/deflate.hpp). Linear data: no sRGB or gamma chunk;
// alpha is stored as given (unassociated), colour is never premultiplied
// by it.
std::vector<std::uint8_t> encodePng(const Image<std::uint16_t>& image, int bits);

// Where a tile's mesh sits on the globe and which image it wears.
struct GlbInfo {
  std::string normal_texture_uri;         // e.g. "5.png", relative to the .glb; empty: none
  double origin_lon_deg = 0;
  double origin_lat_deg = 0;
  std::array<double, 16> enu_to_ecef{};  // column-major, glTF axes -> ECEF
  std::optional<double> max_error_m;     // the mesh's distance to the height samples
  // Where the mesh lies, as a 3D Tiles region: west, south, east, north
  // (radians), lowest and highest point (metres above the ellipsoid).
  std::optional<std::array<double, 6>> region;
};

// glTF 2.0 binary of the low-poly mesh (docs/CONTRACT.md §5).
std::vector<std::uint8_t> encodeGlb(const mesh::TriangleMesh& mesh, const GlbInfo& info);

// What a tileset needs of a .glb written by encodeGlb: its asset.extras.terrabake.
struct GlbPlacement {
  std::array<double, 16> enu_to_ecef{};
  double max_error_m = 0;
  std::array<double, 6> region{};
};
// Reads only the JSON chunk. Throws std::runtime_error when the bytes are not
// a .glb or lack enu_to_ecef, max_error_m or region.
GlbPlacement readGlbPlacement(const std::vector<std::uint8_t>& glb);

// What a layer's tilejson.json says, written by tileJson() and read back by
// readTileJson().
struct TileJsonInfo {
  std::string name;                    // the layer
  SchemeKind scheme{};
  bool tms_rows = false;               // true when y = 0 is the south edge
  int min_zoom = 0;
  int max_zoom = 0;
  std::array<double, 4> bounds_deg{};  // west, south, east, north
  int tile_size = 0;
  int bits = 0;
  Green green{};
  bool alpha = false;                  // RGBA images, alpha 0 where the DEM had no sample
  NodataSurface nodata_surface{};      // what tiles show where the DEM had no sample
  double z_scale = 0;                  // metres per DEM height unit
  double exaggeration = 0;             // vertical exaggeration of normals and meshes
  LowPolyMesh low_poly_mesh{};
  int low_poly_grid = 0;               // grid: vertices a side
  std::map<int, double> max_error_m;   // adaptive: the distance bound of each zoom's meshes
  bool skirts = false;                 // the meshes hang skirts under their edges
  bool tileset = false;                // the layer has a tileset.json (3D Tiles)
  std::vector<std::string> sources;    // DEM paths as the user gave them
  Elevation elevation{};               // the encoding of {y}.elevation.png; none: not written
};

// TileJSON 3.0.0 text with the "terrabake" object (docs/CONTRACT.md §6).
std::string tileJson(const TileJsonInfo& info);
// The tilejson of the layer's elevation tiles (elevation.json), a MapLibre
// raster-dem source: encoding, tileSize, zooms and bounds (§6).
std::string elevationTileJson(const TileJsonInfo& info);

// What a reader of a layer needs from its tilejson: the zooms, bounds and
// row order, and the scheme and tile size when the "terrabake" object names
// them (nullopt / 0 otherwise). Throws std::runtime_error saying what is
// missing or malformed.
struct TileJsonSummary {
  int min_zoom = 0;
  int max_zoom = 0;
  std::array<double, 4> bounds_deg{};  // west, south, east, north
  bool tms_rows = false;               // "scheme": "tms"
  std::optional<SchemeKind> scheme;    // terrabake.scheme
  int tile_size = 0;                   // terrabake.tile_size
};
TileJsonSummary readTileJson(const std::string& text);

// `text` as served over HTTP: each relative URL in "tiles", "terrabake.mesh"
// and "terrabake.elevation" resolved against `layer_url` ("http://host:port/<layer>/";
// other URLs stay as they are: relative URLs would resolve against the viewer
// page, not the tilejson, in many clients), and "terrabake.sources" reduced
// to file names (a glob to its last part), so no local path of the machine
// reaches a web page.
std::string servedTileJson(const std::string& text, const std::string& layer_url);

}  // namespace terrabake::io

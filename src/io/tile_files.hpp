#pragma once
// Writing a layer's files: normal-map images, low-poly meshes, tilejson.
// Every file appears atomically under its final name (temp file + rename).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::io {

// Writes bytes to path through a temporary file in the same folder and a
// rename, creating missing parent folders. Throws InputError naming the path.
void writeFileAtomically(const std::string& path, const std::vector<std::uint8_t>& bytes);

// True for a temporary file of writeFileAtomically whose writer is gone: a
// process of this host that no longer runs, or any writer over a minute ago.
bool isAbandonedTempFile(const std::string& path);

// PNG bytes of an RGB or RGBA image whose samples are 8-bit (0..255) or
// 16-bit (0..65535) values. Linear data: no sRGB or gamma chunk; alpha is
// stored as given (unassociated), colour is never premultiplied by it.
std::vector<std::uint8_t> encodePng(const Image<std::uint16_t>& image, int bits);

// Where a tile's mesh sits on the globe and which image it wears.
struct GlbInfo {
  std::string normal_texture_uri;         // e.g. "5.png", relative to the .glb; empty: none
  double origin_lon_deg = 0;
  double origin_lat_deg = 0;
  std::array<double, 16> enu_to_ecef{};  // column-major, glTF axes -> ECEF
};

// glTF 2.0 binary of the low-poly mesh (docs/CONTRACT.md §5).
std::vector<std::uint8_t> encodeGlb(const mesh::GridMesh& mesh, const GlbInfo& info);

struct TileJsonInfo {
  std::string name;                    // the layer
  std::string scheme;                  // "webmercator", "native", ...
  bool tms_rows = false;               // true when y = 0 is the south edge
  int min_zoom = 0;
  int max_zoom = 0;
  std::array<double, 4> bounds_deg{};  // west, south, east, north
  int tile_size = 256;
  int bits = 8;
  bool green_up = true;
  bool alpha = false;                  // RGBA images, alpha 0 where the DEM had no sample
  double z_scale = 1;                  // metres per DEM height unit
  double exaggeration = 1;             // vertical exaggeration of normals and meshes
  int low_poly_grid = 17;
  std::vector<std::string> sources;    // DEM paths as the user gave them
};

// TileJSON 3.0.0 text with the "terrabake" object (docs/CONTRACT.md §6).
std::string tileJson(const TileJsonInfo& info);

}  // namespace terrabake::io

#pragma once
// How a layer lies on disk (docs/CONTRACT.md §1): the one place that spells
// its file names, extensions and the MBTiles file name. The writers, the
// sinks and the server all go through it.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/choices.hpp"
#include "core/types.hpp"

namespace terrabake::io {

// The files of one tile.
enum class TileFormat { kPng, kGlb, kHighResGlb, kElevationPng };

// "png", "glb", "hires.glb", "elevation.png": the file name extension of a tile in a layer folder.
std::string_view extensionOf(TileFormat format);
// The format whose extension is `extension`; nullopt for any other text.
std::optional<TileFormat> formatOfExtension(std::string_view extension);

// "z/x/y.png": where a tile's file lies in its layer folder.
std::string relativeTilePath(const TileId& tile, TileFormat format);
// "<layer_dir>/z/x/y.png"
std::string tilePath(const std::string& layer_dir, const TileId& tile, TileFormat format);

// Beside the tiles in a layer folder: the layer's tilejson and the record of
// the job that made it.
inline constexpr const char* kTileJsonFile = "tilejson.json";
inline constexpr const char* kJobFile = "terrabake-job.txt";
// Records `fingerprint` in the layer folder's job record when it has none (of
// several writers racing, exactly one records); returns what the record holds.
// Throws InputError naming the record when it cannot be written or read.
std::string recordJob(const std::string& layer_dir, const std::string& fingerprint);
// What the layer folder's job record holds; empty when it has none.
std::string jobRecordOf(const std::string& layer_dir);

// A visible entry of a layer folder that records no job, which a folder only
// terrabake wrote into would not have (hidden files are writers' temporary
// files): the first one found, or nullopt. A writer that starts at the same
// moment may record its job while this looks, and then write tiles: what it
// writes comes after its record, so an entry found is another tool's only
// while there is still no record, which this checks last.
std::optional<std::string> foreignEntry(const std::string& layer_dir);

// With output.elevation: the tilejson of the elevation tiles, a raster-dem source.
inline constexpr const char* kElevationTileJsonFile = "elevation.json";
// A layer stored as one file is "<layer>.mbtiles" beside the layer folders.
inline constexpr const char* kMbtilesExtension = ".mbtiles";
// A layer stored as PMTiles is one archive per kind of tile beside the layer
// folders: "<layer>.pmtiles" (normal maps), "<layer>.meshes.pmtiles",
// "<layer>.hires.pmtiles", "<layer>.elevation.pmtiles".
inline constexpr const char* kPmtilesExtension = ".pmtiles";
// The archive of `format`'s tiles of the layer whose normal maps are in
// `normals_archive` ("<dir>/<layer>.pmtiles").
std::string pmtilesArchive(const std::string& normals_archive, TileFormat format);
// True for "<name>.meshes.pmtiles" and the other archives that go with a
// layer's "<layer>.pmtiles" rather than being a layer themselves.
bool isPmtilesCompanion(const std::string& file_name);

// Where layer `layer` of `output_dir` lives: the folder "<dir>/<layer>", or
// the file "<dir>/<layer>.mbtiles", or the normal maps' archive
// "<dir>/<layer>.pmtiles"; lexically normal.
std::string layerLocation(const std::string& output_dir, const std::string& layer, OutputFormat format);

// One tile's files, made in memory.
struct TileFiles {
  std::vector<std::uint8_t> png;
  std::vector<std::uint8_t> glb;
  std::vector<std::uint8_t> high_res_glb;  // empty unless asked for
  std::vector<std::uint8_t> elevation_png; // empty unless asked for
};

// Writes a tile's files into the layer folder, each atomically; the images
// first, so a reader that finds the mesh also finds its texture and heights.
// Where one cannot be written, the tile's files are removed (it is whole or
// absent) and the error is thrown on.
void writeTileFiles(const std::string& layer_dir, const TileId& tile, const TileFiles& files);

// The files a tile of a layer has, in the order writeTileFiles writes them.
std::vector<TileFormat> tileFormats(bool high_res_mesh, bool elevation);

}  // namespace terrabake::io
